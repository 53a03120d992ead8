#include "glintlab/validation/documents.hpp"

#include <cmath>
#include <cstdint>
#include <map>
#include <set>

namespace glintlab::validation {

namespace detail {
extern const char experiment_schema_text[];  // generated from python/glintlab/data/schema/ (schemas.cpp.in)
extern const char bounds_schema_text[];
extern const char scene_schema_text[];
extern const char report_schema_text[];
extern const char pipeline_schema_text[];
}  // namespace detail

namespace {

using json = nlohmann::json;

const std::map<std::string, std::string>& schema_texts() {
  static const std::map<std::string, std::string> texts{{"experiment", detail::experiment_schema_text},
                                                        {"bounds", detail::bounds_schema_text},
                                                        {"scene", detail::scene_schema_text},
                                                        {"report", detail::report_schema_text},
                                                        {"pipeline", detail::pipeline_schema_text}};
  return texts;
}

// Keyed by file name, which is how bounds.schema.json refers to experiment.schema.json.
const SchemaSet& schemas() {
  static const SchemaSet set({{"experiment.schema.json", schema_text("experiment")},
                              {"bounds.schema.json", schema_text("bounds")},
                              {"scene.schema.json", schema_text("scene")},
                              {"report.schema.json", schema_text("report")},
                              {"pipeline.schema.json", schema_text("pipeline")}});
  return set;
}

// The rules a schema cannot state, run on a schema-valid, normalized document (so every field the
// checks read exists and has its schema type).
struct Checker {
  const std::string& source;

  [[noreturn]] void fail(const std::string& pointer, std::string expected, std::string got) const {
    throw InputError(source, pointer, std::move(expected), std::move(got));
  }

  // Checks an axis (array, {logspace}, {linspace} or "standard") and returns its number of values.
  std::size_t axis(const json& a, const std::string& ptr, bool is_p) const {
    if (a.is_string()) return is_p ? standard_p_count : standard_n_count;
    if (a.is_array()) return a.size();
    const bool log = a.contains("logspace");
    const std::string at = ptr + (log ? "/logspace" : "/linspace");
    const json& t = a[log ? "logspace" : "linspace"];
    const double lo = t[0].get<double>(), hi = t[1].get<double>();
    if (lo > hi) fail(at, "[lo, hi, count] with lo <= hi", render(t));
    if (is_p && log && hi > 0) fail(at + "/1", "an exponent <= 0 (10^hi is a probability)", render(t[1]));
    if (is_p && !log && hi > 1) fail(at + "/1", "a probability <= 1", render(t[1]));
    return t[2].get<std::size_t>();
  }

  // The stratified layout is an M x M grid of cells with one facet each, the uniform layout a whole
  // number of facets: their densities must be integers (a square for stratified).
  void reference(const json& r, const std::string& ptr) const {
    if (!r.is_object() || !r.contains("ground_truth")) return;
    const json& gt = r["ground_truth"];
    const std::string layout = gt["layout"].get<std::string>();
    const json& d = gt["density"];
    const double density = d.get<double>();  // in [1, 1e15] (schema): exact as a 64-bit integer
    const std::string at = ptr + "/ground_truth/density";
    if (layout == "poisson") return;
    if (std::trunc(density) != density) fail(at, "an integer density for the " + layout + " layout", render(d));
    if (layout == "stratified") {
      const auto n = static_cast<std::int64_t>(density);
      const auto m = static_cast<std::int64_t>(std::llround(std::sqrt(density)));
      if (m * m != n && (m - 1) * (m - 1) != n && (m + 1) * (m + 1) != n)
        fail(at, "a square density M*M for the stratified layout (an M x M grid of cells)", render(d));
    }
  }
};

}  // namespace

const std::string& schema_text(const std::string& name) {
  const auto it = schema_texts().find(name);
  if (it == schema_texts().end())
    throw std::invalid_argument("unknown schema \"" + name + "\" (experiment, bounds, scene, report or pipeline)");
  return it->second;
}

json parse_experiment(std::string_view text, const std::string& source) {
  json doc = parse_json(text, source);
  schemas().validate("experiment.schema.json", doc, source);
  const Checker c{source};
  const std::size_t n = c.axis(doc["grid"]["n"], "/grid/n", false);
  const std::size_t p = c.axis(doc["grid"]["p"], "/grid/p", true);
  c.reference(doc["reference"], "/reference");
  const json& metrics = doc["metrics"];
  for (std::size_t i = 0; i < metrics.size(); ++i) {
    const std::string at = "/metrics/" + std::to_string(i);
    for (std::size_t j = 0; j < i; ++j)
      if (metrics[j] == metrics[i])
        c.fail(at, "a metric not listed before (as /metrics/" + std::to_string(j) + ")", render(metrics[i]));
    if (metrics[i] == "chi2_pvalue" && doc["samples"].is_null())
      c.fail(at, "a metric of exact distributions (chi2_pvalue needs \"samples\": a number of draws)",
             render(metrics[i]));
  }
  // n, p <= 1e5 and laws <= 1000 (schema): the product fits in 64 bits.
  const std::size_t rows = doc["laws"].size() * n * p;
  if (rows > max_experiment_rows)
    c.fail("/grid", "at most " + std::to_string(max_experiment_rows) + " rows (laws x n values x p values)",
           std::to_string(doc["laws"].size()) + " x " + std::to_string(n) + " x " + std::to_string(p) + " = " +
               std::to_string(rows));
  return doc;
}

json parse_bounds(std::string_view text, const std::string& source) {
  json doc = parse_json(text, source);
  schemas().validate("bounds.schema.json", doc, source);
  const Checker c{source};
  std::map<std::string, std::size_t> ids;
  const json& bounds = doc["bounds"];
  for (std::size_t i = 0; i < bounds.size(); ++i) {
    const json& b = bounds[i];
    const std::string at = "/bounds/" + std::to_string(i);
    const auto [seen, fresh] = ids.emplace(b["id"].get<std::string>(), i);
    if (!fresh)
      c.fail(at + "/id", "an id not used before (as /bounds/" + std::to_string(seen->second) + "/id)", render(b["id"]));
    // A p-value is good when large, every other metric when small.
    const std::string metric = b["metric"].get<std::string>();
    const bool pvalue = metric == "chi2_pvalue";
    const std::string want = pvalue ? "minimum" : "maximum", other = pvalue ? "maximum" : "minimum";
    if (b.contains(other))
      c.fail(at + "/" + other, "no \"" + other + "\" for the metric " + metric + " (it takes a \"" + want + "\")",
             render(b[other]));
    if (!b.contains(want)) c.fail(at + "/" + want, "the field \"" + want + "\" for the metric " + metric, "nothing");
    if (pvalue && b["samples"].is_null())
      c.fail(at + "/samples", "a number of draws >= 1 (chi2_pvalue tests samples)", "null");
    const json& regime = b["regime"];
    c.axis(regime["n"], at + "/regime/n", false);
    c.axis(regime["p"], at + "/regime/p", true);
    for (const char* key : {"n_range", "p_range", "np_range"})
      if (regime.contains(key) && regime[key][0].get<double>() > regime[key][1].get<double>())
        c.fail(at + "/regime/" + key, "[lo, hi] with lo <= hi", render(regime[key]));
    c.reference(b["reference"], at + "/reference");
  }
  return doc;
}

// Scenes and report configurations: the schema only. The rules beyond it need Python (the scene's
// geometry, the registered report sections) and run there, in the same message format.
json parse_scene(std::string_view text, const std::string& source) {
  json doc = parse_json(text, source);
  schemas().validate("scene.schema.json", doc, source);
  return doc;
}

json parse_report(std::string_view text, const std::string& source) {
  json doc = parse_json(text, source);
  schemas().validate("report.schema.json", doc, source);
  return doc;
}

// Pipelines (glintlab check PIPELINE.json): the schema only. Their stages name registered laws, blends,
// samplers and shader files, which Python resolves (in the same message format).
json parse_pipeline(std::string_view text, const std::string& source) {
  json doc = parse_json(text, source);
  schemas().validate("pipeline.schema.json", doc, source);
  return doc;
}

json parse_document(const std::string& kind, std::string_view text, const std::string& source) {
  if (kind == "experiment") return parse_experiment(text, source);
  if (kind == "bounds") return parse_bounds(text, source);
  if (kind == "scene") return parse_scene(text, source);
  if (kind == "report") return parse_report(text, source);
  if (kind == "pipeline") return parse_pipeline(text, source);
  throw std::invalid_argument("unknown document kind \"" + kind + "\" (experiment, bounds, scene, report or pipeline)");
}

}  // namespace glintlab::validation
