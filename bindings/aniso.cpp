// Anisotropic grids (glintlab/counting/aniso.hpp): the grid schemes' registry, footprint shapes from Jacobians,
// and the counter that sums an inner law's counts over a scheme's grids, per shape or per pixel.
#include <pybind11/functional.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "conversions.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/counting/aniso.hpp"

namespace py = pybind11;

namespace glintlab::bindings {
namespace {

using CounterClass = py::class_<aniso::AnisoCounter, std::shared_ptr<aniso::AnisoCounter>>;

void bind_grid_schemes(py::module_& m) {
  m.def("grid_scheme_infos", [] {
    std::vector<std::pair<std::string, std::string>> out;
    for (const auto& info : aniso::registered_grid_schemes()) out.emplace_back(info.name, info.summary);
    return out;
  });
  m.def(
      "grid_scheme_traits",
      [](const std::string& name) {
        const auto info = aniso::grid_scheme_registry().find(name);
        py::dict d;
        d["name"] = info.name;
        d["summary"] = info.summary;
        d["native_law"] = info.traits.native_law;
        return d;
      },
      py::arg("name"));
  m.def(
      "footprint_shapes",
      [](const Array& jac) {
        // jac: (m, 4) rows (du/dx, dv/dx, du/dy, dv/dy) -> (m, 5) rows (P, a, b, r, phi) and status codes.
        const auto m_rows = static_cast<std::size_t>(jac.size() / 4);
        py::array_t<double> shapes({static_cast<py::ssize_t>(m_rows), static_cast<py::ssize_t>(5)});
        py::array_t<std::uint8_t> status(static_cast<py::ssize_t>(m_rows));
        const double* j = jac.data();
        double* o = shapes.mutable_data();
        std::uint8_t* st = status.mutable_data();
        for (std::size_t i = 0; i < m_rows; ++i) {
          const aniso::Shape s = aniso::shape_from_jacobian(j[4 * i], j[4 * i + 1], j[4 * i + 2], j[4 * i + 3]);
          o[5 * i] = s.area, o[5 * i + 1] = s.major, o[5 * i + 2] = s.minor, o[5 * i + 3] = s.ratio,
                o[5 * i + 4] = s.angle;
          st[i] = static_cast<std::uint8_t>(s.status);
        }
        return py::make_tuple(shapes, status);
      },
      py::arg("jac"));
}

// One row per grid term of a footprint shape (AnisoCounter::terms), as a dict.
py::tuple terms_rows(const aniso::AnisoCounter& c, double density, double area, double ratio, double angle) {
  bool clamped = false;
  const auto ts = c.terms(density, aniso::shape_from_params(area, ratio, angle), &clamped);
  py::list rows;
  for (const auto& t : ts) {
    py::dict d;
    d["scale_level"] = t.grid.scale;
    d["ratio_level"] = t.grid.ratio;
    d["orientation"] = t.grid.orientation;
    d["angle"] = t.angle;
    d["cell_minor"] = t.cell_minor;
    d["cell_major"] = t.cell_major;
    d["cell_area"] = t.cell_area;
    d["dx"] = t.dx;
    d["dy"] = t.dy;
    d["weight"] = t.weight;
    d["trials"] = t.trials;
    d["scale"] = t.scale;
    rows.append(d);
  }
  return py::make_tuple(rows, clamped);
}

py::tuple count_pixels(const aniso::AnisoCounter& c, double density, const Array& p, const Array& uv, const Array& jac,
                       std::optional<Array> slope, std::uint64_t seed) {
  const auto m_rows = static_cast<std::size_t>(uv.size() / 2);
  if (static_cast<std::size_t>(jac.size()) != 4 * m_rows)
    glintlab::throw_invalid_message("J has " + std::to_string(jac.size() / 4) + " pixels; uv has " +
                                    std::to_string(m_rows));
  if (slope && static_cast<std::size_t>(slope->size()) != 2 * m_rows)
    glintlab::throw_invalid_message("slope has " + std::to_string(slope->size() / 2) + " pixels; uv has " +
                                    std::to_string(m_rows));
  const auto rows = static_cast<py::ssize_t>(m_rows);
  py::array_t<double> k(rows);
  py::array_t<std::int32_t> evals(rows);
  py::array_t<std::uint8_t> status(rows);
  aniso::PixelOutput out{k.mutable_data(), evals.mutable_data(), status.mutable_data()};
  const double* sl = slope ? slope->data() : nullptr;
  {
    LongCall release;
    c.count_pixels(density, param(p), uv.data(), jac.data(), sl, m_rows, seed, out);
  }
  return py::make_tuple(k, evals, status);
}

void bind_counter_counts(CounterClass& counter) {
  counter
      .def(
          "pmf",
          [](const aniso::AnisoCounter& c, double density, double area, double ratio, double angle, double p,
             std::size_t max_support) {
            const auto shape = aniso::shape_from_params(area, ratio, angle);
            LongCall release;
            return c.pmf(density, p, shape, max_support);
          },
          py::arg("N"), py::arg("P"), py::arg("r"), py::arg("phi"), py::arg("p"),
          py::arg("max_support") = kDefaultMaxSupport)
      .def(
          "sample",
          [](const aniso::AnisoCounter& c, double density, double area, double ratio, double angle, double p,
             std::size_t count, std::uint64_t seed, const py::object& out_arg) {
            const auto shape = aniso::shape_from_params(area, ratio, angle);
            OutArray out = output_array(out_arg, count);
            double* o = out.mutable_data();
            {
              LongCall release;
              c.sample(density, p, shape, count, seed, o);
            }
            return out;
          },
          py::arg("N"), py::arg("P"), py::arg("r"), py::arg("phi"), py::arg("p"), py::arg("count"), py::arg("seed"),
          py::arg("out") = py::none())
      .def("count_pixels", &count_pixels, py::arg("N"), py::arg("p"), py::arg("uv"), py::arg("jac"), py::arg("slope"),
           py::arg("seed"));
}

void bind_aniso_counter(py::module_& m) {
  CounterClass counter(m, "AnisoCounter");
  counter.def_property_readonly("scheme_name", [](const aniso::AnisoCounter& c) { return c.scheme().name(); })
      .def_property_readonly("scheme_params",
                             [](const aniso::AnisoCounter& c) { return from_params(c.scheme().params()); })
      .def_property_readonly("evaluations_per_term", &aniso::AnisoCounter::evaluations_per_term)
      .def_property_readonly("integer_output", &aniso::AnisoCounter::integer_output)
      .def_property_readonly("has_pmf", &aniso::AnisoCounter::has_pmf)
      .def("terms", &terms_rows, py::arg("N"), py::arg("P"), py::arg("r"), py::arg("phi"));
  bind_counter_counts(counter);
}

aniso::CounterOptions counter_options(const std::string& spatial, const std::string& angular,
                                      const std::string& realization) {
  return aniso::CounterOptions{aniso::spatial_from_name(spatial), aniso::angular_from_name(angular),
                               aniso::realization_from_name(realization)};
}

void bind_counter_factories(py::module_& m) {
  m.def(
      "make_aniso_counter",
      [](const std::string& scheme, const py::dict& kwargs, std::shared_ptr<CountingLaw> inner,
         const std::string& spatial, const std::string& angular, const std::string& realization) {
        std::shared_ptr<const aniso::GridScheme> s = aniso::make_grid_scheme(scheme, to_params(kwargs));
        return std::make_shared<aniso::AnisoCounter>(s, InnerLaw::from_law(std::move(inner)),
                                                     counter_options(spatial, angular, realization));
      },
      py::arg("scheme"), py::arg("params"), py::arg("inner"), py::arg("spatial"), py::arg("angular"),
      py::arg("realization"));
  m.def(
      "make_aniso_counter_custom",
      [](const std::string& scheme, const py::dict& kwargs, py::function fn, int n_uniforms,
         const std::string& inner_name, const std::string& spatial, const std::string& angular,
         const std::string& realization) {
        std::shared_ptr<const aniso::GridScheme> s = aniso::make_grid_scheme(scheme, to_params(kwargs));
        return std::make_shared<aniso::AnisoCounter>(s, python_inner(fn, n_uniforms, inner_name),
                                                     counter_options(spatial, angular, realization));
      },
      py::arg("scheme"), py::arg("params"), py::arg("fn"), py::arg("n_uniforms"), py::arg("inner_name"),
      py::arg("spatial"), py::arg("angular"), py::arg("realization"));
}

}  // namespace

void bind_aniso(py::module_& m) {
  bind_grid_schemes(m);
  bind_aniso_counter(m);
  bind_counter_factories(m);
}

}  // namespace glintlab::bindings
