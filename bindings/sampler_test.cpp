// The direction-sampler harness's core (core/include/glintlab/sampling/sampler_test.hpp): the bins with their
// pull interface (nodes / supply), the binning of samples and the chi-square. The Python driver is
// glintlab.validation.sampler_test; the GIL is released while points are binned.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <string>
#include <vector>

#include "bindings.hpp"
#include "glintlab/base/errors.hpp"
#include "glintlab/sampling/sampler_test.hpp"

namespace py = pybind11;

namespace glintlab::bindings {

namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;
using sampling::BinOptions;
using sampling::Bins;
using sampling::Domain;

BinOptions options(double total, double target, int min_depth, int max_depth, int max_sub_depth, double rel_tol,
                   std::size_t max_nodes, double shift_tol, double min_expected) {
  BinOptions o;
  o.total = total;
  o.target = target;
  o.min_depth = min_depth;
  o.max_depth = max_depth;
  o.max_sub_depth = max_sub_depth;
  o.rel_tol = rel_tol;
  o.max_nodes = max_nodes;
  o.shift_tol = shift_tol;
  o.min_expected = min_expected;
  return o;
}

std::size_t points_of(Domain d, const Array& points) {
  const auto dim = static_cast<std::size_t>(sampling::domain_dim(d));
  const auto n = static_cast<std::size_t>(points.size()) / dim;
  if (n * dim != static_cast<std::size_t>(points.size()))
    glintlab::throw_invalid_message(std::string("sampler_test: points must hold ") + std::to_string(dim) +
                                    " coordinates each on the " + sampling::domain_name(d));
  return n;
}

Bins adaptive_bins(const std::string& domain, double total, double target, int min_depth, int max_depth,
                   int max_sub_depth, double rel_tol, std::size_t max_nodes, const Array& pilot_s, const Array& pilot_t,
                   double pilot_drawn, const Array& pilot_pdf, double shift_tol, double min_expected) {
  if (pilot_s.size() != pilot_t.size())
    glintlab::throw_invalid_message("sampler_test: pilot_s and pilot_t differ in length");
  auto o = options(total, target, min_depth, max_depth, max_sub_depth, rel_tol, max_nodes, shift_tol, min_expected);
  o.pilot_drawn = pilot_drawn;
  if (pilot_pdf.size() != 0 && pilot_pdf.size() != pilot_s.size())
    glintlab::throw_invalid_message("sampler_test: pilot_pdf and pilot_s differ in length");
  return Bins(sampling::parse_domain(domain), o, pilot_s.data(), pilot_t.data(),
              static_cast<std::size_t>(pilot_s.size()), pilot_pdf.size() ? pilot_pdf.data() : nullptr);
}

Bins grid_bins(const std::string& domain, double total, int max_sub_depth, double rel_tol, std::size_t max_nodes,
               std::vector<double> s_edges, std::vector<double> t_edges, double shift_tol, double min_expected) {
  return Bins(sampling::parse_domain(domain),
              options(total, 1.0, 0, 0, max_sub_depth, rel_tol, max_nodes, shift_tol, min_expected), std::move(s_edges),
              std::move(t_edges));
}

py::array_t<double> rects_of(const Bins& b) {
  const auto& r = b.rects();
  py::array_t<double> out({static_cast<py::ssize_t>(r.size()), py::ssize_t{4}});
  double* o = out.mutable_data();
  for (std::size_t i = 0; i < r.size(); ++i) {
    o[4 * i] = r[i].s0;
    o[4 * i + 1] = r[i].t0;
    o[4 * i + 2] = r[i].ws;
    o[4 * i + 3] = r[i].wt;
  }
  return out;
}

py::array_t<std::int64_t> locate(const Bins& b, const Array& s, const Array& t) {
  if (s.size() != t.size()) glintlab::throw_invalid_message("sampler_test: s and t differ in length");
  py::array_t<std::int64_t> out(s.size());
  b.locate(s.data(), t.data(), static_cast<std::size_t>(s.size()), out.mutable_data());
  return out;
}

py::tuple count(const Bins& b, const std::string& domain, const Array& points, double unit_tol) {
  const Domain d = sampling::parse_domain(domain);
  const std::size_t n = points_of(d, points);
  std::vector<double> counts;
  double lost = 0.0;
  {
    LongCall release;
    b.count(d, points.data(), n, unit_tol, counts, lost);
  }
  return py::make_tuple(py::array_t<double>(py::cast(counts)), lost);
}

py::tuple to_square(const std::string& domain, const Array& points, double unit_tol) {
  const Domain d = sampling::parse_domain(domain);
  const std::size_t n = points_of(d, points);
  py::array_t<double> s(static_cast<py::ssize_t>(n)), t(static_cast<py::ssize_t>(n));
  py::array_t<std::uint8_t> lost(static_cast<py::ssize_t>(n));
  sampling::to_square(d, points.data(), n, unit_tol, s.mutable_data(), t.mutable_data(), lost.mutable_data());
  return py::make_tuple(s, t, lost);
}

py::array_t<double> from_square(const std::string& domain, const Array& s, const Array& t) {
  const Domain d = sampling::parse_domain(domain);
  if (s.size() != t.size()) glintlab::throw_invalid_message("sampler_test: s and t differ in length");
  const int dim = sampling::domain_dim(d);
  py::array_t<double> out({static_cast<py::ssize_t>(s.size()), static_cast<py::ssize_t>(dim)});
  for (py::ssize_t i = 0; i < s.size(); ++i)
    sampling::from_square(d, s.data()[i], t.data()[i], out.mutable_data() + dim * i);
  return out;
}

py::dict chi_square(const std::vector<double>& observed, const std::vector<double>& integral,
                    const std::vector<double>& error, double lost, double total, double min_expected) {
  const auto r = sampling::chi_square(observed, integral, error, lost, total, min_expected);
  py::dict out;
  out["statistic"] = r.statistic;
  out["dof"] = r.dof;
  out["pvalue"] = r.pvalue;
  out["pvalue_chi2"] = r.pvalue_chi2;
  out["pvalue_lost"] = r.pvalue_lost;
  out["starts"] = py::array_t<std::size_t>(py::cast(r.starts));
  out["observed"] = py::array_t<double>(py::cast(r.observed));
  out["expected"] = py::array_t<double>(py::cast(r.expected));
  out["lost_expected"] = r.lost_expected;
  out["lost_observed"] = r.lost_observed;
  out["note"] = r.note;
  return out;
}

template <class T>
py::array_t<T> array_of(const std::vector<T>& v) {  // a copy, without a Python list in between
  py::array_t<T> out(static_cast<py::ssize_t>(v.size()));
  std::copy(v.begin(), v.end(), out.mutable_data());
  return out;
}

// The class: its three constructions (adaptive, grid, a grid over resolved bins) and the pull interface.
void bind_bins(py::module_& m) {
  py::class_<Bins>(m, "SamplerBins")
      .def(py::init(&adaptive_bins), py::arg("domain"), py::arg("total"), py::arg("target"), py::arg("min_depth"),
           py::arg("max_depth"), py::arg("max_sub_depth"), py::arg("rel_tol"), py::arg("max_nodes"), py::arg("pilot_s"),
           py::arg("pilot_t"), py::arg("pilot_drawn"), py::arg("pilot_pdf"), py::arg("shift_tol") = 0.0,
           py::arg("min_expected") = 5.0)
      .def_static("grid", &grid_bins, py::arg("domain"), py::arg("total"), py::arg("max_sub_depth"), py::arg("rel_tol"),
                  py::arg("max_nodes"), py::arg("s_edges"), py::arg("t_edges"), py::arg("shift_tol") = 0.0,
                  py::arg("min_expected") = 5.0)
      .def_static(
          "regrid",
          [](const Bins& resolved, std::vector<double> s, std::vector<double> t) {
            return Bins(resolved, std::move(s), std::move(t));
          },
          py::arg("resolved"), py::arg("s_edges"), py::arg("t_edges"))
      .def_property_readonly("done", &Bins::done)
      .def("nodes", [](const Bins& b) { return array_of(b.nodes()); })
      .def(
          "supply",
          [](Bins& b, const Array& values) { b.supply(values.data(), static_cast<std::size_t>(values.size())); },
          py::arg("values"))
      .def_property_readonly("size", &Bins::size)
      .def("rects", &rects_of)
      .def_property_readonly("depths", [](const Bins& b) { return array_of(b.depths()); })
      .def_property_readonly("integral", [](const Bins& b) { return array_of(b.integral()); })
      .def_property_readonly("error", [](const Bins& b) { return array_of(b.error()); })
      .def_property_readonly("evaluations", &Bins::evaluations)
      .def_property_readonly("rounds", &Bins::rounds)
      .def_property_readonly("unconverged", &Bins::unconverged)
      .def_property_readonly("shift_bound", &Bins::shift_bound)
      .def_property_readonly("shift_limit", &Bins::shift_limit)
      .def_property_readonly("mass_error", &Bins::mass_error)
      .def_property_readonly("mass_limit", &Bins::mass_limit)
      .def_property_readonly("unresolved_peaks", &Bins::unresolved_peaks)
      .def_property_readonly("unresolved_reach", &Bins::unresolved_reach)
      .def("locate", &locate, py::arg("s"), py::arg("t"))
      .def("count", &count, py::arg("domain"), py::arg("points"), py::arg("unit_tol"));
}

}  // namespace

void bind_sampler_test(py::module_& m) {
  bind_bins(m);
  m.def("sampler_to_square", &to_square, py::arg("domain"), py::arg("points"), py::arg("unit_tol"));
  m.def("sampler_from_square", &from_square, py::arg("domain"), py::arg("s"), py::arg("t"));
  m.def(
      "sampler_domain_measure",
      [](const std::string& domain) { return sampling::domain_measure(sampling::parse_domain(domain)); },
      py::arg("domain"));
  m.def("sampler_chi_square", &chi_square, py::arg("observed"), py::arg("integral"), py::arg("error"), py::arg("lost"),
        py::arg("total"), py::arg("min_expected"));
}

}  // namespace glintlab::bindings
