// WWH18's filterable model and its discrete-flake truth: core/include/glintlab/glinty/wwh18.hpp. Arrays arrive
// flattened and shape-checked by glintlab.api.wwh18; the GIL is released while pixels are computed.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <string>

#include "bindings.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/glinty/wwh18.hpp"
#include "glintlab/lighting/lighting.hpp"
#include "glintlab/lighting/lobes.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
using IArray = py::array_t<std::int64_t, py::array::c_style | py::array::forcecast>;
constexpr char kWhere[] = "glinty_ndf wwh18";

std::size_t pixels(const Array& uv, const Array& jac, const Array& h) {
  const auto m = static_cast<std::size_t>(h.size() / 3);
  if (static_cast<std::size_t>(h.size()) != 3 * m || static_cast<std::size_t>(jac.size()) != 4 * m ||
      static_cast<std::size_t>(uv.size()) != 2 * m)
    glintlab::throw_invalid_message("glinty_ndf wwh18: uv, J and h must hold 2, 4 and 3 numbers per pixel");
  return m;
}

template <class E>
E pick(const std::string& name, const std::string& value, std::initializer_list<std::pair<const char*, E>> options) {
  std::string known;
  for (const auto& [k, e] : options) {
    if (value == k) return e;
    known += (known.empty() ? "\"" : ", \"") + std::string(k) + "\"";
  }
  throw_invalid(kWhere, name, value, "one of " + known);
}

// An optional (n, 3) array of directions (None: null).
const double* optional_directions(const py::object& obj, Array& keep, std::size_t n, const char* name) {
  if (obj.is_none()) return nullptr;
  keep = obj.cast<Array>();
  if (static_cast<std::size_t>(keep.size()) != 3 * n)
    glintlab::throw_invalid_message(std::string("glinty_ndf wwh18: ") + name + " must hold 3 numbers per pixel");
  return keep.data();
}

// A function of one direction (or a pair) evaluated per row, the GIL released.
template <class F>
py::array_t<double> per_row(const Array& a, F&& f) {
  const auto n = static_cast<std::size_t>(a.size() / 3);
  py::array_t<double> out(static_cast<py::ssize_t>(n));
  double* o = out.mutable_data();
  const double* d = a.data();
  {
    py::gil_scoped_release release;
    for (std::size_t i = 0; i < n; ++i) o[i] = f(d + 3 * i, i);
  }
  return out;
}

using WwhClass = py::class_<Wwh18Ndf>;

Wwh18Params wwh18_params(double density, const std::string& target, double alpha, double gamma, double flakes_per_cell,
                         const std::string& lambda_seeding, const std::string& threshold_test, const std::string& rng,
                         int tea_rounds, double error_eps, double T, const std::string& dpf, double table_res,
                         double lod, bool float32, const std::string& cone) {
  Wwh18Params p;
  p.density = density;
  p.target = pick<GlintTarget>("target", target, {{"beckmann", GlintTarget::beckmann}, {"ggx", GlintTarget::ggx}});
  p.alpha = alpha;
  p.gamma_deg = gamma;
  p.flakes_per_cell = flakes_per_cell;
  p.lambda_seeding = pick<WwhLambdaSeeding>(
      "lambda_seeding", lambda_seeding,
      {{"node", WwhLambdaSeeding::node}, {"flake", WwhLambdaSeeding::flake}, {"pixel", WwhLambdaSeeding::pixel}});
  p.threshold_test =
      pick<WwhThresholdTest>("threshold_test", threshold_test,
                             {{"printed", WwhThresholdTest::printed}, {"flipped", WwhThresholdTest::flipped}});
  p.rng = pick<WwhRng>("rng", rng, {{"tea", WwhRng::tea}, {"philox", WwhRng::philox}});
  p.tea_rounds = tea_rounds;
  p.error_eps = error_eps;
  p.T = T;
  p.dpf = pick<WwhDpf>("dpf", dpf, {{"table", WwhDpf::table}, {"exact", WwhDpf::exact}});
  p.table_res_deg = table_res;
  p.lod_deg = lod;
  p.float32 = float32;
  p.cone = pick<WwhCone>("cone", cone, {{"half_vector", WwhCone::half_vector}, {"outgoing", WwhCone::outgoing}});
  return p;
}

void bind_wwh18_init(WwhClass& cls) {
  cls.def(py::init([](double density, const std::string& target, double alpha, double gamma, double flakes_per_cell,
                      const std::string& lambda_seeding, const std::string& threshold_test, const std::string& rng,
                      int tea_rounds, double error_eps, double T, const std::string& dpf, double table_res, double lod,
                      bool float32, const std::string& cone) {
            const Wwh18Params p =
                wwh18_params(density, target, alpha, gamma, flakes_per_cell, lambda_seeding, threshold_test, rng,
                             tea_rounds, error_eps, T, dpf, table_res, lod, float32, cone);
            py::gil_scoped_release release;  // the table build runs on the OpenMP threads
            return Wwh18Ndf(p);
          }),
          py::arg("density"), py::arg("target"), py::arg("alpha"), py::arg("gamma"), py::arg("flakes_per_cell"),
          py::arg("lambda_seeding"), py::arg("threshold_test"), py::arg("rng"), py::arg("tea_rounds"),
          py::arg("error_eps"), py::arg("T"), py::arg("dpf"), py::arg("table_res"), py::arg("lod"), py::arg("float32"),
          py::arg("cone") = "half_vector")
      .def_property_readonly("cell_side", &Wwh18Ndf::cell_side)
      .def_property_readonly("cone_solid_angle", &Wwh18Ndf::cone_solid_angle)
      .def_property_readonly(
          "table_shape",
          [](const Wwh18Ndf& g) { return py::make_tuple(g.table_size(0), g.table_size(1), g.table_size(2)); })
      .def_property_readonly("table_bytes", &Wwh18Ndf::table_bytes);
}

// The counts: the truth's and the model's.
void bind_wwh18_counts(WwhClass& cls) {
  cls.def(
         "reference_counts",
         [](const Wwh18Ndf& g, const Array& uv, const Array& jac, const Array& h, std::uint64_t seed,
            const py::object& wi_obj) {
           const std::size_t n = pixels(uv, jac, h);
           Array wi;
           const double* w = optional_directions(wi_obj, wi, n, "wi");
           py::array_t<double> out(static_cast<py::ssize_t>(n));
           double* o = out.mutable_data();
           {
             LongCall release;
             g.reference_counts(uv.data(), jac.data(), h.data(), n, seed, o, w);
           }
           return out;
         },
         py::arg("uv"), py::arg("J"), py::arg("h"), py::arg("seed"), py::arg("wi") = py::none())
      .def(
          "light_counts",
          [](const Wwh18Ndf& g, const Array& uv, const Array& jac, const Array& wo, std::uint64_t seed,
             const lighting::LightHit& hit, const lighting::GlintLightOptions& opt) {
            const std::size_t n = pixels(uv, jac, wo);
            const auto k = static_cast<py::ssize_t>(hit.channels());
            py::array_t<double> counts({static_cast<py::ssize_t>(n), k}), rad(static_cast<py::ssize_t>(n)),
                flakes(static_cast<py::ssize_t>(n));
            double* c = counts.mutable_data();
            double* r = rad.mutable_data();
            double* f = flakes.mutable_data();
            {
              LongCall release;
              g.light_counts(uv.data(), jac.data(), wo.data(), n, seed, hit, opt, c, r, f);
            }
            return py::make_tuple(counts, rad, flakes);
          },
          py::arg("uv"), py::arg("J"), py::arg("wo"), py::arg("seed"), py::arg("hit"), py::arg("options"))
      .def(
          "counts",
          [](const Wwh18Ndf& g, const Array& uv, const Array& jac, const Array& h, const py::object& wi_obj,
             std::uint64_t seed) {
            const std::size_t n = pixels(uv, jac, h);
            Array wi;
            const double* w = optional_directions(wi_obj, wi, n, "wi");
            py::array_t<double> out(static_cast<py::ssize_t>(n)), pv(static_cast<py::ssize_t>(n));
            py::array_t<int> mode(static_cast<py::ssize_t>(n));
            double* o = out.mutable_data();
            double* q = pv.mutable_data();
            int* md = mode.mutable_data();
            {
              LongCall release;
              g.counts(uv.data(), jac.data(), h.data(), w, n, seed, o, md, q);
            }
            return py::make_tuple(out, mode, pv);
          },
          py::arg("uv"), py::arg("J"), py::arg("h"), py::arg("wi"), py::arg("seed"));
}

// The directional probability: exact masses, the table and its look-ups, the generator.
void bind_wwh18_directions(WwhClass& cls) {
  cls.def(
         "cone_mass",
         [](const Wwh18Ndf& g, const Array& h) {
           return per_row(h, [&](const double* x, std::size_t) { return g.cone_mass(x); });
         },
         py::arg("h"))
      .def(
          "outgoing_cone_mass",
          [](const Wwh18Ndf& g, const Array& wi, const Array& wo) {
            if (wo.size() != wi.size()) glintlab::throw_invalid_message("glinty_ndf wwh18: wi and wo differ in size");
            const double* o = wo.data();
            return per_row(wi, [&](const double* x, std::size_t i) { return g.outgoing_cone_mass(x, o + 3 * i); });
          },
          py::arg("wi"), py::arg("wo"))
      .def(
          "accumulated",
          [](const Wwh18Ndf& g, const Array& h) {
            return per_row(h, [&](const double* x, std::size_t) { return g.accumulated(x); });
          },
          py::arg("h"))
      .def(
          "dpf",
          [](const Wwh18Ndf& g, const Array& wi, const Array& wo) {
            if (wo.size() != wi.size()) glintlab::throw_invalid_message("glinty_ndf wwh18: wi and wo differ in size");
            const double* o = wo.data();
            return per_row(wi, [&](const double* x, std::size_t i) { return g.dpf(x, o + 3 * i); });
          },
          py::arg("wi"), py::arg("wo"))
      .def(
          "model_p",
          [](const Wwh18Ndf& g, const Array& h) {
            return per_row(h, [&](const double* x, std::size_t) { return g.model_p(x, nullptr); });
          },
          py::arg("h"))
      .def(
          "lambdas",
          [](const Wwh18Ndf& g, std::uint64_t seed, int level, const IArray& i, const IArray& j, std::uint32_t k) {
            if (i.size() != j.size()) glintlab::throw_invalid_message("glinty_ndf wwh18: i and j differ in size");
            py::array_t<double> out(i.size());
            double* o = out.mutable_data();
            for (py::ssize_t q = 0; q < i.size(); ++q) o[q] = g.lambda(seed, level, i.data()[q], j.data()[q], k);
            return out;
          },
          py::arg("seed"), py::arg("level"), py::arg("i"), py::arg("j"), py::arg("k"))
      .def("pixel_lambda", &Wwh18Ndf::pixel_lambda, py::arg("seed"), py::arg("u"), py::arg("v"));
}

}  // namespace

void bind_wwh18(py::module_& m) {
  WwhClass cls(m, "Wwh18Ndf");
  bind_wwh18_init(cls);
  bind_wwh18_counts(cls);
  bind_wwh18_directions(cls);
}

}  // namespace glintlab::bindings
