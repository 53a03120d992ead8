// Glinty NDFs (KPT25's point process, its reference and Algorithm 1): core/include/glintlab/glinty/glinty_ndf.hpp.
// Arrays arrive flattened and checked for shape by glintlab.api.glinty_ndf; the GIL is released while the
// pixels are computed (the core splits them over OpenMP threads).
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <string_view>
#include <utility>

#include "bindings.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/glinty/glinty_ndf.hpp"
#include "glintlab/lighting/lighting.hpp"
#include "glintlab/lighting/lobes.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
constexpr char kWhere[] = "glinty_ndf kpt25";

GlintTarget parse_target(const std::string& s) {
  static constexpr std::pair<std::string_view, GlintTarget> kTargets[] = {{"beckmann", GlintTarget::beckmann},
                                                                          {"ggx", GlintTarget::ggx}};
  return parse_enum(kWhere, "target", s, kTargets);
}
GlintCompensation parse_compensation(const std::string& s) {
  static constexpr std::pair<std::string_view, GlintCompensation> kCompensations[] = {
      {"square", GlintCompensation::square},
      {"disk", GlintCompensation::disk},
      {"none", GlintCompensation::none},
      {"square_flipped", GlintCompensation::square_flipped}};
  return parse_enum(kWhere, "compensation", s, kCompensations);
}
GlintBlend parse_blend(const std::string& s) {
  static constexpr std::pair<std::string_view, GlintBlend> kBlends[] = {{"roulette", GlintBlend::roulette},
                                                                        {"linear", GlintBlend::linear}};
  return parse_enum(kWhere, "blend", s, kBlends);
}

std::size_t pixels(const Array& uv, const Array* jac, const Array& h) {
  const auto m = static_cast<std::size_t>(h.size() / 3);
  if (static_cast<std::size_t>(h.size()) != 3 * m || (jac && static_cast<std::size_t>(jac->size()) != 4 * m) ||
      static_cast<std::size_t>(uv.size()) != 2 * m)
    glintlab::throw_invalid_message("glinty_ndf: uv, J and h must hold 2, 4 and 3 numbers per pixel");
  return m;
}

using Kpt25Class = py::class_<Kpt25Ndf>;

// The constructor's arguments, parsed into the core's parameters (each bad value named).
Kpt25Params kpt25_params(double density, const std::string& target, double alpha, double alpha_star, int k,
                         double epsilon, double filter, const std::string& compensation, const std::string& blend,
                         double sample_smooth, const std::string& sample_weight, const std::string& ggx_map,
                         double alpha_y, double glint_ax, double glint_ay, bool glint_printed_density,
                         const std::string& triplanar_weights, double triplanar_sharpness,
                         const std::string& plane_seeds, const std::string& lambert_jacobian) {
  Kpt25Params p;
  p.density = density;
  p.target = parse_target(target);
  p.alpha = alpha;
  p.alpha_star = alpha_star;
  p.k = k;
  p.epsilon = epsilon;
  p.filter = filter;
  p.compensation = parse_compensation(compensation);
  p.blend = parse_blend(blend);
  p.sample_smooth = sample_smooth;
  static constexpr std::pair<std::string_view, bool> kWeights[] = {{"lobe_mass", true}, {"printed", false}};
  p.sample_lobe_mass = parse_enum(kWhere, "sample_weight", sample_weight, kWeights);
  p.alpha_y = alpha_y;
  p.glint_ax = glint_ax;
  p.glint_ay = glint_ay;
  p.glint_printed_density = glint_printed_density;
  static constexpr std::pair<std::string_view, TriplanarWeights> kPlaneWeights[] = {
      {"normalized", TriplanarWeights::normalized},
      {"printed", TriplanarWeights::printed},
      {"missing_xy", TriplanarWeights::missing_xy}};
  p.triplanar_weights = parse_enum(kWhere, "triplanar_weights", triplanar_weights, kPlaneWeights);
  p.triplanar_sharpness = triplanar_sharpness;
  static constexpr std::pair<std::string_view, bool> kSeeds[] = {{"distinct", false}, {"shared", true}};
  p.triplanar_shared_seeds = parse_enum(kWhere, "plane_seeds", plane_seeds, kSeeds);
  if (ggx_map == "orthographic")
    p.ggx_lambert = false;
  else if (ggx_map == "lambert" && p.target == GlintTarget::ggx)
    p.ggx_lambert = true;
  else
    throw_invalid(kWhere, "ggx_map", ggx_map, "\"orthographic\", or \"lambert\" with target \"ggx\"");
  static constexpr std::pair<std::string_view, bool> kJacobians[] = {{"map", false}, {"printed", true}};
  p.lambert_printed_jacobian = parse_enum(kWhere, "lambert_jacobian", lambert_jacobian, kJacobians);
  return p;
}

void bind_kpt25_init(Kpt25Class& cls) {
  cls.def(py::init([](double density, const std::string& target, double alpha, double alpha_star, int k, double epsilon,
                      double filter, const std::string& compensation, const std::string& blend, double sample_smooth,
                      const std::string& sample_weight, const std::string& ggx_map, double alpha_y, double glint_ax,
                      double glint_ay, bool glint_printed_density, const std::string& triplanar_weights,
                      double triplanar_sharpness, const std::string& plane_seeds, const std::string& lambert_jacobian) {
            return Kpt25Ndf(kpt25_params(density, target, alpha, alpha_star, k, epsilon, filter, compensation, blend,
                                         sample_smooth, sample_weight, ggx_map, alpha_y, glint_ax, glint_ay,
                                         glint_printed_density, triplanar_weights, triplanar_sharpness, plane_seeds,
                                         lambert_jacobian));
          }),
          py::arg("density"), py::arg("target"), py::arg("alpha"), py::arg("alpha_star"), py::arg("k"),
          py::arg("epsilon"), py::arg("filter"), py::arg("compensation"), py::arg("blend"),
          py::arg("sample_smooth") = 0.0, py::arg("sample_weight") = "lobe_mass", py::arg("ggx_map") = "orthographic",
          py::arg("alpha_y") = 0.0, py::arg("glint_ax") = 1.0, py::arg("glint_ay") = 1.0,
          py::arg("glint_printed_density") = false, py::arg("triplanar_weights") = "normalized",
          py::arg("triplanar_sharpness") = 1.0, py::arg("plane_seeds") = "distinct",
          py::arg("lambert_jacobian") = "map");
}

// Algorithm 1, the reference, their expectations and the visible glints.
void bind_kpt25_evaluation(Kpt25Class& cls) {
  cls.def(
         "evaluate",
         [](const Kpt25Ndf& g, const Array& uv, const Array& jac, const Array& h, std::uint64_t seed) {
           const std::size_t n = pixels(uv, &jac, h);
           py::array_t<double> out(static_cast<py::ssize_t>(n));
           double* o = out.mutable_data();
           {
             glintlab::bindings::LongCall release;
             g.evaluate(uv.data(), jac.data(), h.data(), n, seed, o);
           }
           return out;
         },
         py::arg("uv"), py::arg("J"), py::arg("h"), py::arg("seed"))
      .def(
          "reference",
          [](const Kpt25Ndf& g, const Array& uv, const Array& jac, const Array& h, std::uint64_t seed, double tol) {
            const std::size_t n = pixels(uv, &jac, h);
            py::array_t<double> out(static_cast<py::ssize_t>(n)), pts(static_cast<py::ssize_t>(n));
            double* o = out.mutable_data();
            double* q = pts.mutable_data();
            {
              glintlab::bindings::LongCall release;
              g.reference(uv.data(), jac.data(), h.data(), n, seed, o, q, tol);
            }
            return py::make_tuple(out, pts);
          },
          py::arg("uv"), py::arg("J"), py::arg("h"), py::arg("seed"), py::arg("tol") = 0.0)
      .def(
          "expected",
          [](const Kpt25Ndf& g, const Array& jac, const Array& h) {
            const auto n = static_cast<std::size_t>(h.size() / 3);
            if (static_cast<std::size_t>(jac.size()) != 4 * n || static_cast<std::size_t>(h.size()) != 3 * n)
              glintlab::throw_invalid_message("glinty_ndf: J and h must hold 4 and 3 numbers per pixel");
            py::array_t<double> er(static_cast<py::ssize_t>(n)), ea(static_cast<py::ssize_t>(n));
            double* a = er.mutable_data();
            double* b = ea.mutable_data();
            {
              glintlab::bindings::LongCall release;
              g.expected(jac.data(), h.data(), n, a, b);
            }
            return py::make_tuple(er, ea);
          },
          py::arg("J"), py::arg("h"))
      .def(
          "visible_counts",
          [](const Kpt25Ndf& g, const Array& uv, const Array& jac, const Array& h, std::uint64_t seed, double radius) {
            const std::size_t n = pixels(uv, &jac, h);
            py::array_t<double> out(static_cast<py::ssize_t>(n));
            double* o = out.mutable_data();
            {
              glintlab::bindings::LongCall release;
              g.visible_counts(uv.data(), jac.data(), h.data(), n, seed, radius, o);
            }
            return out;
          },
          py::arg("uv"), py::arg("J"), py::arg("h"), py::arg("seed"), py::arg("radius"));
}

// KPT25's points lit by an extended light (docs/math/lighting.md#lighting-lobes).
void bind_kpt25_lights(Kpt25Class& cls) {
  cls.def(
         "footprint_ndf",
         [](const Kpt25Ndf& g, const Array& uv, const Array& jac, const Array& h, std::uint64_t seed) {
           const std::size_t n = pixels(uv, &jac, h);
           py::array_t<double> out(static_cast<py::ssize_t>(n));
           double* o = out.mutable_data();
           {
             glintlab::bindings::LongCall release;
             g.footprint_ndf(uv.data(), jac.data(), h.data(), n, seed, o);
           }
           return out;
         },
         py::arg("uv"), py::arg("J"), py::arg("h"), py::arg("seed"))
      .def(
          "light_counts",
          [](const Kpt25Ndf& g, const Array& uv, const Array& jac, const Array& h, const Array& wo, std::uint64_t seed,
             const lighting::LightHit& hit, const lighting::GlintLightOptions& opt) {
            const std::size_t n = pixels(uv, &jac, h);
            if (static_cast<std::size_t>(wo.size()) != 3 * n)
              glintlab::throw_invalid_message("glinty_ndf: wo must hold 3 numbers per pixel");
            const auto k = static_cast<py::ssize_t>(hit.channels());
            py::array_t<double> counts({static_cast<py::ssize_t>(n), k}), rad(static_cast<py::ssize_t>(n)),
                points(static_cast<py::ssize_t>(n));
            double* c = counts.mutable_data();
            double* r = rad.mutable_data();
            double* p = points.mutable_data();
            {
              glintlab::bindings::LongCall release;
              g.light_counts(uv.data(), jac.data(), h.data(), wo.data(), n, seed, hit, opt, c, r, p);
            }
            return py::make_tuple(counts, rad, points);
          },
          py::arg("uv"), py::arg("J"), py::arg("h"), py::arg("wo"), py::arg("seed"), py::arg("hit"),
          py::arg("options"));
}

// Per-facet colour (RGB evaluate and reference).
void bind_kpt25_colour(Kpt25Class& cls) {
  cls.def(
      "evaluate_rgb",
      [](const Kpt25Ndf& g, const Array& uv, const Array& jac, const Array& h, std::uint64_t seed, const Array& palette,
         bool reference) {
        const std::size_t n = pixels(uv, &jac, h);
        if (palette.size() % 3 != 0)
          glintlab::throw_invalid_message("glinty_ndf: colors must hold 3 numbers per colour");
        const int nc = static_cast<int>(palette.size() / 3);
        py::array_t<double> out(static_cast<py::ssize_t>(3 * n));
        double* o = out.mutable_data();
        {
          glintlab::bindings::LongCall release;
          if (reference)
            g.reference_rgb(uv.data(), jac.data(), h.data(), n, seed, palette.data(), nc, o);
          else
            g.evaluate_rgb(uv.data(), jac.data(), h.data(), n, seed, palette.data(), nc, o);
        }
        return out;
      },
      py::arg("uv"), py::arg("J"), py::arg("h"), py::arg("seed"), py::arg("palette"), py::arg("reference"));
}

// UV-free glints: the three planes and their roulette.
void bind_kpt25_triplanar(Kpt25Class& cls) {
  cls.def(
         "evaluate_triplanar",
         [](const Kpt25Ndf& g, const Array& P, const Array& dP, const Array& n, const Array& h, std::uint64_t seed,
            bool reference) {
           const auto rows = static_cast<std::size_t>(h.size() / 3);
           if (static_cast<std::size_t>(h.size()) != 3 * rows || static_cast<std::size_t>(P.size()) != 3 * rows ||
               static_cast<std::size_t>(n.size()) != 3 * rows || static_cast<std::size_t>(dP.size()) != 6 * rows)
             glintlab::throw_invalid_message(
                 "glinty_ndf: position, dP, n and h must hold 3, 6, 3 and 3 numbers per pixel");
           py::array_t<double> out(static_cast<py::ssize_t>(rows)), pts(static_cast<py::ssize_t>(rows));
           double* o = out.mutable_data();
           double* q = pts.mutable_data();
           {
             glintlab::bindings::LongCall release;
             if (reference)
               g.reference_triplanar(P.data(), dP.data(), n.data(), h.data(), rows, seed, o, q);
             else
               g.evaluate_triplanar(P.data(), dP.data(), n.data(), h.data(), rows, seed, o);
           }
           return py::make_tuple(out, pts);
         },
         py::arg("position"), py::arg("dP"), py::arg("n"), py::arg("h"), py::arg("seed"), py::arg("reference"))
      .def(
          "expected_triplanar",
          [](const Kpt25Ndf& g, const Array& dP, const Array& n, const Array& h) {
            const auto rows = static_cast<std::size_t>(h.size() / 3);
            if (static_cast<std::size_t>(h.size()) != 3 * rows || static_cast<std::size_t>(n.size()) != 3 * rows ||
                static_cast<std::size_t>(dP.size()) != 6 * rows)
              glintlab::throw_invalid_message("glinty_ndf: dP, n and h must hold 6, 3 and 3 numbers per pixel");
            py::array_t<double> er(static_cast<py::ssize_t>(rows)), ea(static_cast<py::ssize_t>(rows));
            double* a = er.mutable_data();
            double* b = ea.mutable_data();
            {
              glintlab::bindings::LongCall release;
              g.expected_triplanar(dP.data(), n.data(), h.data(), rows, a, b);
            }
            return py::make_tuple(er, ea);
          },
          py::arg("dP"), py::arg("n"), py::arg("h"))
      .def(
          "triplanar_weights",
          [](const Kpt25Ndf& g, const Array& n) {
            if (n.size() != 3) glintlab::throw_invalid_message("glinty_ndf: triplanar_weights takes one normal");
            return g.triplanar_weights(n.data());
          },
          py::arg("n"))
      .def("keep_rate", &Kpt25Ndf::keep_rate, py::arg("w"));
}

// Algorithm 2: sample and pdf.
void bind_kpt25_sampling(Kpt25Class& cls) {
  cls.def(
         "pdf",
         [](const Kpt25Ndf& g, const Array& uv, const Array& jac, const Array& h, std::uint64_t seed) {
           const std::size_t n = pixels(uv, &jac, h);
           py::array_t<double> out(static_cast<py::ssize_t>(n));
           double* o = out.mutable_data();
           {
             glintlab::bindings::LongCall release;
             g.pdf(uv.data(), jac.data(), h.data(), n, seed, o);
           }
           return out;
         },
         py::arg("uv"), py::arg("J"), py::arg("h"), py::arg("seed"))
      .def(
          "sample",
          [](const Kpt25Ndf& g, const Array& uv, const Array& jac, std::uint64_t seed, std::uint64_t draw_seed,
             std::optional<Array> wo) {
            const auto n = static_cast<std::size_t>(uv.size() / 2);
            if (static_cast<std::size_t>(uv.size()) != 2 * n || static_cast<std::size_t>(jac.size()) != 4 * n ||
                (wo && static_cast<std::size_t>(wo->size()) != 3 * n))
              glintlab::throw_invalid_message("glinty_ndf: uv, J and wo must hold 2, 4 and 3 numbers per row");
            py::array_t<double> h(static_cast<py::ssize_t>(3 * n)), pdf(static_cast<py::ssize_t>(n));
            py::array_t<double> wi(static_cast<py::ssize_t>(wo ? 3 * n : 0));
            double* ph = h.mutable_data();
            double* pp = pdf.mutable_data();
            double* pw = wi.mutable_data();
            const double* pwo = wo ? wo->data() : nullptr;
            {
              glintlab::bindings::LongCall release;
              g.sample(uv.data(), jac.data(), pwo, n, seed, draw_seed, ph, pp, wo ? pw : nullptr);
            }
            return py::make_tuple(h, pdf, wi);
          },
          py::arg("uv"), py::arg("J"), py::arg("seed"), py::arg("draw_seed"), py::arg("wo"));
}

// The map T and the pixel set-up.
void bind_kpt25_geometry(Kpt25Class& cls) {
  cls.def(
         "map",
         [](const Kpt25Ndf& g, const Array& h) {
           const auto n = static_cast<std::size_t>(h.size() / 3);
           if (static_cast<std::size_t>(h.size()) != 3 * n)
             glintlab::throw_invalid_message("glinty_ndf: h must hold 3 numbers per row");
           py::array_t<double> xy(static_cast<py::ssize_t>(2 * n));
           double* o = xy.mutable_data();
           {
             glintlab::bindings::LongCall release;
             g.map_points(h.data(), n, o);
           }
           return xy;
         },
         py::arg("h"))
      .def(
          "pixel",
          [](const Kpt25Ndf& g, const Array& jac, const Array& h) {
            if (jac.size() != 4 || h.size() != 3)
              glintlab::throw_invalid_message("glinty_ndf: pixel takes one J and one h");
            const GlintPixel px = g.pixel(jac.data(), h.data(), 0);
            py::dict d;
            d["D"] = px.D;
            d["xa"] = px.xa;
            d["ya"] = px.ya;
            d["sigma"] = px.sigma;
            d["lambda"] = px.lambda;
            py::list levels, weights;
            for (int l = 0; l < px.n_levels; ++l) {
              levels.append(px.levels[l]);
              weights.append(px.weights[l]);
            }
            d["levels"] = levels;
            d["weights"] = weights;
            d["half_u"] = px.half_u;
            d["half_v"] = px.half_v;
            return d;
          },
          py::arg("J"), py::arg("h"));
}

}  // namespace

void bind_glinty_ndf(py::module_& m) {
  Kpt25Class cls(m, "Kpt25Ndf");
  bind_kpt25_init(cls);
  bind_kpt25_evaluation(cls);
  bind_kpt25_lights(cls);
  bind_kpt25_colour(cls);
  bind_kpt25_triplanar(cls);
  bind_kpt25_sampling(cls);
  bind_kpt25_geometry(cls);
  m.def("rect_disk_area", &rect_disk_area, py::arg("x0"), py::arg("x1"), py::arg("y0"), py::arg("y1"));
  m.def("kpt25_roulette", &kpt25_roulette, py::arg("r"), py::arg("w"), py::arg("eps"));
  m.def("gaussian_in_disk_rect", &gaussian_in_disk_rect, py::arg("cx"), py::arg("cy"), py::arg("sigma"), py::arg("x0"),
        py::arg("x1"), py::arg("y0"), py::arg("y1"));
}

}  // namespace glintlab::bindings
