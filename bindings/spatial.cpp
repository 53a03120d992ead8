// Spatialized Bernoulli trials, the ground truth (glintlab/counting/spatial.hpp): footprints, the ground truth's
// exact law and samples, stratified coverage and the joint counts of several footprints.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "bindings.hpp"
#include "conversions.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/counting/spatial.hpp"

namespace py = pybind11;

namespace glintlab::bindings {
namespace {

using spatial::Footprint;

void bind_footprint(py::module_& m) {
  py::class_<Footprint>(m, "Footprint")
      .def_static("rect", &Footprint::rect, py::arg("width"), py::arg("height"), py::arg("angle") = 0.0)
      .def_static("ellipse", &Footprint::ellipse, py::arg("a"), py::arg("b"), py::arg("angle") = 0.0)
      .def_static("from_uv_derivatives", &Footprint::from_uv_derivatives, py::arg("dudx"), py::arg("dvdx"),
                  py::arg("dudy"), py::arg("dvdy"))
      .def_property_readonly("kind",
                             [](const Footprint& f) { return f.kind() == Footprint::Kind::kRect ? "rect" : "ellipse"; })
      .def_property_readonly("a", &Footprint::a)
      .def_property_readonly("b", &Footprint::b)
      .def_property_readonly("angle", &Footprint::angle)
      .def_property_readonly("area", &Footprint::area)
      .def_property_readonly("half_width", &Footprint::half_width)
      .def_property_readonly("half_height", &Footprint::half_height)
      .def("contains", py::vectorize(&Footprint::contains), py::arg("x"), py::arg("y"))
      .def("overlap", &Footprint::overlap, py::arg("x0"), py::arg("y0"), py::arg("x1"), py::arg("y1"))
      .def("__repr__", &Footprint::describe);
}

void bind_ground_truth(py::module_& m) {
  py::class_<spatial::GroundTruth>(m, "GroundTruth")
      .def(py::init([](const std::string& layout, double density, const Footprint& fp, double p,
                       std::optional<std::pair<double, double>> center) {
             return spatial::GroundTruth(spatial::parse_layout(layout), density, fp, p, center);
           }),
           py::arg("layout"), py::arg("density"), py::arg("footprint"), py::arg("p"), py::arg("center") = py::none())
      .def_property_readonly("layout", [](const spatial::GroundTruth& g) { return spatial::layout_name(g.layout()); })
      .def_property_readonly("density", &spatial::GroundTruth::density)
      .def_property_readonly("p", &spatial::GroundTruth::p)
      .def_property_readonly("n", &spatial::GroundTruth::n)
      .def_property_readonly("grid_side", &spatial::GroundTruth::grid_side)
      .def_property_readonly("footprint", &spatial::GroundTruth::footprint)
      .def_property_readonly("center", &spatial::GroundTruth::center)
      .def("pmf", &spatial::GroundTruth::pmf, py::arg("max_support") = kDefaultMaxSupport, py::arg("quadrature") = 16,
           py::call_guard<LongCall>())
      .def(
          "sample",
          [](const spatial::GroundTruth& g, std::size_t count, std::uint64_t seed) {
            std::vector<double> out;
            {
              LongCall release;
              out = g.sample(count, seed);
            }
            return to_numpy(out);
          },
          py::arg("count"), py::arg("seed"));
}

void bind_coverage_and_joint_counts(py::module_& m) {
  m.def(
      "stratified_coverage",
      [](const Footprint& f, double x, double y, std::int64_t side) {
        const auto cov = spatial::stratified_coverage(f, x, y, side);
        return py::make_tuple(cov.interior, to_numpy(cov.fractions));
      },
      py::arg("footprint"), py::arg("x"), py::arg("y"), py::arg("side"));
  m.def(
      "joint_counts",
      [](const std::string& layout, double density, double p, const std::vector<Footprint>& fps,
         const std::vector<std::pair<double, double>>& centers, std::size_t count, std::uint64_t seed) {
        if (fps.size() != centers.size())
          glintlab::throw_invalid_message("joint_counts: " + std::to_string(fps.size()) + " footprints but " +
                                          std::to_string(centers.size()) +
                                          " centers; expected one center per footprint");
        std::vector<spatial::Placed> placed;
        for (std::size_t j = 0; j < fps.size(); ++j) placed.push_back({fps[j], centers[j].first, centers[j].second});
        const auto lay = spatial::parse_layout(layout);
        std::vector<double> out;
        {
          LongCall release;
          out = spatial::joint_counts(lay, density, p, placed, count, seed);
        }
        auto arr = to_numpy(out);
        return arr.reshape({static_cast<py::ssize_t>(count), static_cast<py::ssize_t>(fps.size())});
      },
      py::arg("layout"), py::arg("density"), py::arg("p"), py::arg("footprints"), py::arg("centers"), py::arg("count"),
      py::arg("seed"));
}

}  // namespace

void bind_spatial(py::module_& m) {
  bind_footprint(m);
  bind_ground_truth(m);
  bind_coverage_and_joint_counts(m);
}

}  // namespace glintlab::bindings
