// Experiment, bounds, scene, report and pipeline documents: the schema validator (every keyword glintlab's
// schemas use), the rules beyond the schema, and the error messages (pointer, expected, got) users see.
#include <catch2/catch.hpp>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "glintlab/validation/documents.hpp"
#include "glintlab/validation/json_schema.hpp"

using glintlab::validation::InputError;
using glintlab::validation::parse_bounds;
using glintlab::validation::parse_document;
using glintlab::validation::parse_experiment;
using glintlab::validation::SchemaSet;
using json = nlohmann::json;
using Files = std::vector<std::pair<std::string, std::string>>;  // (file name, schema text)

namespace {

std::string read_file(const std::string& relative) {
  std::ifstream in(std::string(GLINTLAB_SOURCE_DIR) + "/" + relative, std::ios::binary);
  REQUIRE(in.good());
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

json experiment() { return json::parse(R"({"laws": ["binomial"], "grid": {"n": [1, 10], "p": [0.5]}})"); }

json bounds() { return json::parse(R"({"bounds": [{"id": "a", "law": "gated", "metric": "tv", "maximum": 0.1}]})"); }

json scene() {
  return json::parse(
      R"({"camera": {"resolution": [64, 36], "fov_deg": 60, "position": [0, -4.5, 0.3], "look_at": [0, 0, 0]},
                         "primitive": {"type": "sphere", "center": [0, 0, 0], "radius": 1},
                         "light": {"type": "point", "position": [1.5, -4.5, 1.5]},
                         "material": {"density": 1000}})");
}

json report() {
  return json::parse(R"({"kind": "report", "sections": [{"name": "exact_laws", "params": {"samples": 10}}]})");
}

// The InputError a document raises (the test fails if it parses).
InputError error_text(const std::string& kind, const std::string& text) {
  try {
    parse_document(kind, text, "t.json");
  } catch (const InputError& e) { return e; }
  FAIL("no InputError for " << text);
  throw std::logic_error("unreachable");
}
InputError error_of(const std::string& kind, const json& doc) { return error_text(kind, doc.dump()); }

}  // namespace

TEST_CASE("documents: a minimal experiment gets every default", "[documents]") {
  json in = experiment();
  in["laws"] = json::parse(
      R"(["binomial", {"name": "zk16"}, {"name": "mine", "python": "m:f"}, {"name": "p", "plugin": "x.so"}])");
  const json doc = parse_experiment(in.dump(), "t.json");
  CHECK(doc["glintlab"] == 1);
  CHECK(doc["name"] == "experiment");
  CHECK(doc["description"] == "");
  CHECK(doc["metrics"] == json::parse(R"(["tv", "mean_rel_err", "var_rel_err"])"));
  CHECK(doc["reference"] == "binomial");
  CHECK(doc["samples"].is_null());
  CHECK(doc["seed"] == 1);
  CHECK(doc["outputs"] == json::parse(R"({"csv": true, "json": true, "plots": true})"));  // {} then its defaults
  CHECK(doc["laws"][0] == "binomial");                                                    // strings stay strings
  CHECK(doc["laws"][1] == json::parse(R"({"name": "zk16", "params": {}})"));              // only the matched branch
  CHECK(doc["laws"][2] == json::parse(R"({"name": "mine", "python": "m:f", "n_uniforms": 2, "binning": "none"})"));
  CHECK(doc["laws"][3] == json::parse(R"({"name": "p", "plugin": "x.so"})"));
  // Normalizing is idempotent, and values given are kept.
  CHECK(parse_experiment(doc.dump(), "t.json") == doc);
  in["outputs"] = {{"plots", false}};
  CHECK(parse_experiment(in.dump(), "t.json")["outputs"] ==
        json::parse(R"({"csv": true, "json": true, "plots": false})"));
}

TEST_CASE("documents: ground truth references and bounds get their defaults", "[documents]") {
  json in = experiment();
  in["reference"] = {{"ground_truth", {{"density", 1024}}}};
  CHECK(parse_experiment(in.dump(), "t.json")["reference"]["ground_truth"] ==
        json::parse(R"({"layout": "stratified", "density": 1024, "footprint": "rect", "aspect": 1, "angle": 0})"));
  const json b = parse_bounds(bounds().dump(), "b.json");
  CHECK(b["glintlab"] == 1);
  CHECK(b["margin"] == "");
  const json& bound = b["bounds"][0];
  CHECK(bound["regime"] ==
        json::parse(R"({"n": "standard", "p": "standard"})"));  // {} then the $ref siblings' defaults
  CHECK(bound["reference"] == "binomial");                      // the default inside the $ref target
  CHECK(bound["samples"].is_null());
  CHECK(bound["seed"] == 1);
  CHECK(bound["measured"].is_null());
  CHECK(bound["note"] == "");
  CHECK(bound["law"] == "gated");
  const json all = parse_bounds(read_file("python/glintlab/data/bounds/default.json"), "default.json");
  CHECK(all["bounds"].size() > 10);
}

TEST_CASE("documents: the error message format", "[documents]") {
  json in = experiment();
  in["laws"][0] = {{"name", "zk16"}, {"params", {{"cap", true}}}};
  try {
    parse_experiment(in.dump(), "exp.json");
    FAIL("accepted");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()) == "exp.json: at /laws/0/params/cap: expected a number or a string, got true");
    CHECK(e.source() == "exp.json");
    CHECK(e.pointer() == "/laws/0/params/cap");
    CHECK(e.expected() == "a number or a string");
    CHECK(e.got() == "true");
  }
  // The root is shown as "/"; InputError is a std::invalid_argument.
  const InputError e = error_text("experiment", "[]");
  CHECK(e.pointer().empty());
  CHECK_THAT(e.what(), Catch::StartsWith("t.json: at /: expected "));
  CHECK_THROWS_AS(parse_experiment("[]", "x"), std::invalid_argument);
  CHECK_THROWS_AS(parse_document("nonsense", "{}", "x"), std::invalid_argument);
}

TEST_CASE("documents: schema keyword errors name the pointer and what was expected", "[documents]") {
  SECTION("type, with the schema's description") {
    json in = experiment();
    in["samples"] = "many";
    const InputError e = error_of("experiment", in);
    CHECK(e.pointer() == "/samples");
    CHECK(e.expected() == "null (exact distributions) or the number of draws per grid point (an integer >= 1)");
    CHECK(e.got() == "\"many\"");
  }
  SECTION("type, without a description: the type names") {
    json in = experiment();
    in["outputs"] = {{"csv", 1}};
    const InputError e = error_of("experiment", in);
    CHECK(e.pointer() == "/outputs/csv");
    CHECK(e.expected() == "a boolean");
  }
  SECTION("enum") {
    json in = experiment();
    in["metrics"] = {"tv", "TV"};
    const InputError e = error_of("experiment", in);
    CHECK(e.pointer() == "/metrics/1");
    CHECK_THAT(e.expected(), Catch::StartsWith("one of \"tv\", \"chi2_distance\", "));
    in = experiment();
    in["glintlab"] = 2;
    CHECK(error_of("experiment", in).expected() == "1");
  }
  SECTION("required") {
    json in = experiment();
    in["grid"].erase("p");
    const InputError e = error_of("experiment", in);
    CHECK(e.pointer() == "/grid/p");
    CHECK(e.expected() == "the required field \"p\"");
    CHECK(e.got() == "nothing");
  }
  SECTION("additionalProperties false: the typo and the fields allowed") {
    json in = experiment();
    in["outputs"] = {{"cvs", true}};
    const InputError e = error_of("experiment", in);
    CHECK(e.pointer() == "/outputs/cvs");
    CHECK(e.expected() == "one of the fields csv, json, plots");
    CHECK(e.got() == "\"cvs\"");
    in = experiment();
    in["grid"]["n"] = {{"logspace", {0, 1, 3}}, {"linspace", {0, 1, 3}}};  // two branches fail alike: the oneOf
    CHECK(error_of("experiment", in).pointer() == "/grid/n");
  }
  SECTION("minItems, maxItems, minLength, maxLength, minimum, maximum") {
    json in = experiment();
    in["laws"] = json::array();
    CHECK(error_of("experiment", in).expected() == "an array of at least 1 item");
    in = experiment();
    in["metrics"] = json::array();
    for (int i = 0; i < 65; ++i) in["metrics"].push_back("tv");
    CHECK(error_of("experiment", in).expected() == "an array of at most 64 items");
    in = experiment();
    in["name"] = "";
    CHECK(error_of("experiment", in).expected() == "a non-empty string");
    in["name"] = std::string(201, 'x');
    const InputError e = error_of("experiment", in);
    CHECK(e.expected() == "a string of at most 200 characters");
    CHECK(e.got().size() <= 60);
    in["name"] = "\xc3\xa9" + std::string(199, 'x');  // 200 characters in 201 bytes
    CHECK_NOTHROW(parse_experiment(in.dump(), "t.json"));
    in = experiment();
    in["grid"]["p"] = {0.5, 1.5};
    CHECK(error_of("experiment", in).expected() == "a number <= 1");
    in = experiment();
    in["seed"] = -1;
    CHECK(error_of("experiment", in).expected() == "an integer >= 0");
    in["seed"] = 9007199254740992ULL;  // 2^53: exactly one above the maximum
    CHECK(error_of("experiment", in).pointer() == "/seed");
    in["seed"] = 9007199254740991ULL;
    CHECK(parse_experiment(in.dump(), "t.json")["seed"] == 9007199254740991ULL);
  }
}

TEST_CASE("documents: oneOf reports the branch the user meant", "[documents]") {
  SECTION("a built-in law object with a typo in its fields") {
    json in = experiment();
    in["laws"][0] = {{"name", "zk16"}, {"parms", {{"cap", 3}}}};
    const InputError e = error_of("experiment", in);
    CHECK(e.pointer() == "/laws/0/parms");
    CHECK(e.expected() == "one of the fields name, params");
  }
  SECTION("no branch has the value's type: the oneOf's description") {
    json in = experiment();
    in["laws"][0] = 3;
    const InputError e = error_of("experiment", in);
    CHECK(e.pointer() == "/laws/0");
    CHECK_THAT(e.expected(), Catch::StartsWith("a law name, or an object {name, params}"));
    CHECK(e.got() == "3");
  }
  SECTION("one type-matching branch: its deepest error") {
    json in = experiment();
    in["grid"]["n"] = {1, -1};
    CHECK(error_of("experiment", in).pointer() == "/grid/n/1");
    in["grid"]["n"] = {{"logspace", {0, 1}}};
    const InputError e = error_of("experiment", in);
    CHECK(e.pointer() == "/grid/n/logspace");
    CHECK(e.expected() == "an array of exactly 3 items");
    in["grid"]["n"] = "standrd";
    CHECK(error_of("experiment", in).expected() == "\"standard\"");
  }
  SECTION("nested oneOf: a law inside a reference") {
    json in = experiment();
    in["reference"] = {{"law", {{"name", "x"}, {"python", "m"}}}};
    const InputError e = error_of("experiment", in);
    CHECK(e.pointer() == "/reference/law/python");
    CHECK(e.expected() == "a string of at least 3 characters");
    in["reference"] = {{"law", {{"name", "x"}, {"python", "m:f"}}}};
    CHECK(parse_experiment(in.dump(), "t.json")["reference"]["law"]["n_uniforms"] == 2);
  }
}

TEST_CASE("documents: integers and numbers", "[documents]") {
  json in = experiment();
  in["seed"] = 2.0;  // a number with an integral value is an integer (draft-07), stored as one
  in["samples"] = 1e3;
  const json doc = parse_experiment(in.dump(), "t.json");
  CHECK(doc["seed"].is_number_integer());
  CHECK(doc["seed"] == 2);
  CHECK(doc["samples"].is_number_integer());
  in["seed"] = 2.5;
  const InputError e = error_of("experiment", in);
  CHECK(e.pointer() == "/seed");
  CHECK(e.expected() == "an integer seed in [0, 2^53)");
  in = experiment();
  in["grid"]["n"] = {1.5, 2};  // numbers stay numbers
  CHECK(parse_experiment(in.dump(), "t.json")["grid"]["n"][0] == 1.5);
  in["samples"] = true;  // a boolean is no number
  CHECK(error_of("experiment", in).pointer() == "/samples");
}

TEST_CASE("documents: tuple items", "[documents]") {
  json in = experiment();
  in["grid"]["n"] = {{"logspace", {0, 6, 2.5}}};
  InputError e = error_of("experiment", in);
  CHECK(e.pointer() == "/grid/n/logspace/2");
  CHECK(e.expected() == "an integer");
  in["grid"]["n"] = {{"logspace", {-301, 6, 10}}};
  e = error_of("experiment", in);
  CHECK(e.pointer() == "/grid/n/logspace/0");
  CHECK(e.expected() == "a number >= -300");
  in["grid"]["n"] = {{"linspace", {0, 6, 100001}}};
  CHECK(error_of("experiment", in).expected() == "an integer <= 100000");
  in["grid"]["n"] = {{"linspace", {0, 6, 10.0}}};
  CHECK(parse_experiment(in.dump(), "t.json")["grid"]["n"]["linspace"][2].is_number_integer());
}

TEST_CASE("documents: bounds use the experiment schema's definitions", "[documents]") {
  json b = bounds();
  b["bounds"][0]["law"] = {{"name", "zk16"}, {"params", {{"cap", nullptr}}}};
  InputError e = error_of("bounds", b);
  CHECK(e.pointer() == "/bounds/0/law/params/cap");
  CHECK(e.expected() == "a number or a string");
  b = bounds();
  b["bounds"][0]["metric"] = "TV";
  e = error_of("bounds", b);
  CHECK(e.pointer() == "/bounds/0/metric");
  CHECK_THAT(e.expected(), Catch::StartsWith("one of \"tv\""));
  b = bounds();
  b["bounds"][0]["regime"] = {{"n", {{"linspace", {1, 2, 0}}}}};
  CHECK(error_of("bounds", b).pointer() == "/bounds/0/regime/n/linspace/2");
  b = bounds();
  b["bounds"][0]["reference"] = {{"ground_truth", {{"density", 16}, {"layout", "grid"}}}};
  CHECK(error_of("bounds", b).pointer() == "/bounds/0/reference/ground_truth/layout");
}

TEST_CASE("documents: experiment rules beyond the schema", "[documents]") {
  const auto check = [](const json& in, const std::string& pointer, const std::string& expected) {
    const InputError e = error_of("experiment", in);
    CHECK(e.pointer() == pointer);
    CHECK_THAT(e.expected(), Catch::Contains(expected));
  };
  json in = experiment();
  in["grid"]["n"] = {{"logspace", {3, 1, 5}}};
  check(in, "/grid/n/logspace", "lo <= hi");
  in["grid"]["n"] = {{"linspace", {3, 1, 5}}};
  check(in, "/grid/n/linspace", "lo <= hi");
  in = experiment();
  in["grid"]["p"] = {{"logspace", {-3, 0.5, 5}}};
  check(in, "/grid/p/logspace/1", "an exponent <= 0");
  in["grid"]["p"] = {{"linspace", {0, 1.5, 5}}};
  check(in, "/grid/p/linspace/1", "a probability <= 1");
  in["grid"]["p"] = {{"logspace", {-3, 0, 5}}};
  CHECK_NOTHROW(parse_experiment(in.dump(), "t.json"));
  in["grid"]["p"] = {{"linspace", {0, 1, 5}}};
  CHECK_NOTHROW(parse_experiment(in.dump(), "t.json"));

  in = experiment();
  in["reference"] = {{"ground_truth", {{"layout", "uniform"}, {"density", 10.5}}}};
  check(in, "/reference/ground_truth/density", "an integer density for the uniform layout");
  in["reference"]["ground_truth"]["layout"] = "poisson";
  CHECK_NOTHROW(parse_experiment(in.dump(), "t.json"));
  in["reference"]["ground_truth"] = {{"density", 1000}};  // stratified by default
  check(in, "/reference/ground_truth/density", "a square density");
  in["reference"]["ground_truth"]["density"] = 1e15;  // not a square (10^7.5)
  check(in, "/reference/ground_truth/density", "a square density");
  in["reference"]["ground_truth"]["density"] = 31622776.0 * 31622776.0;  // a square near the maximum
  CHECK_NOTHROW(parse_experiment(in.dump(), "t.json"));
  in["reference"]["ground_truth"]["density"] = 31622776.0 * 31622776.0 + 1;
  check(in, "/reference/ground_truth/density", "a square density");

  in = experiment();
  in["metrics"] = {"tv", "ks", "tv"};
  check(in, "/metrics/2", "a metric not listed before (as /metrics/0)");
  in["metrics"] = {"tv", "chi2_pvalue"};
  check(in, "/metrics/1", "chi2_pvalue needs \"samples\"");
  in["samples"] = 1000;
  CHECK_NOTHROW(parse_experiment(in.dump(), "t.json"));

  in = experiment();
  in["laws"] = {"a", "b", "c"};
  in["grid"] = {{"n", {{"linspace", {1, 2, 100000}}}}, {"p", {{"linspace", {0, 1, 34}}}}};  // 3 x 1e5 x 34 > 1e7
  const InputError e = error_of("experiment", in);
  CHECK(e.pointer() == "/grid");
  CHECK(e.got() == "3 x 100000 x 34 = 10200000");
  in["grid"]["p"]["linspace"][2] = 33;
  CHECK_NOTHROW(parse_experiment(in.dump(), "t.json"));
  in["grid"] = {{"n", "standard"}, {"p", "standard"}};  // 51 x 47 per law
  in["laws"] = json::array();
  for (int i = 0; i < 1000; ++i) in["laws"].push_back("binomial");
  CHECK_NOTHROW(parse_experiment(in.dump(), "t.json"));
}

TEST_CASE("documents: bounds rules beyond the schema", "[documents]") {
  const auto check = [](const json& in, const std::string& pointer, const std::string& expected) {
    const InputError e = error_of("bounds", in);
    CHECK(e.pointer() == pointer);
    CHECK_THAT(e.expected(), Catch::Contains(expected));
  };
  json b = bounds();
  b["bounds"][0]["minimum"] = 0.5;  // both
  check(b, "/bounds/0/minimum", "no \"minimum\" for the metric tv");
  b["bounds"][0].erase("maximum");  // minimum only, for a distance
  check(b, "/bounds/0/minimum", "no \"minimum\"");
  b["bounds"][0].erase("minimum");  // neither
  check(b, "/bounds/0/maximum", "the field \"maximum\" for the metric tv");
  b = bounds();
  b["bounds"][0]["metric"] = "chi2_pvalue";
  check(b, "/bounds/0/maximum", "no \"maximum\" for the metric chi2_pvalue");
  b["bounds"][0].erase("maximum");
  check(b, "/bounds/0/minimum", "the field \"minimum\"");
  b["bounds"][0]["minimum"] = 1e-6;
  check(b, "/bounds/0/samples", "a number of draws");
  b["bounds"][0]["samples"] = 100000;
  CHECK_NOTHROW(parse_bounds(b.dump(), "b.json"));

  b = bounds();
  b["bounds"].push_back(b["bounds"][0]);
  b["bounds"].push_back(b["bounds"][0]);
  b["bounds"][1]["id"] = "b";
  check(b, "/bounds/2/id", "an id not used before (as /bounds/0/id)");
  b = bounds();
  b["bounds"][0]["regime"] = {{"np_range", {10, 1}}};
  check(b, "/bounds/0/regime/np_range", "lo <= hi");
  b["bounds"][0]["regime"] = {{"p", {{"logspace", {-2, 1, 3}}}}};
  check(b, "/bounds/0/regime/p/logspace/1", "an exponent <= 0");
  b["bounds"][0]["regime"] = {{"p_range", {0, 0.5}}, {"n", {{"logspace", {0, 3, 4}}}}};
  CHECK_NOTHROW(parse_bounds(b.dump(), "b.json"));
  b["bounds"][0]["reference"] = {{"ground_truth", {{"density", 17}}}};
  check(b, "/bounds/0/reference/ground_truth/density", "a square density");
}

TEST_CASE("documents: invalid JSON and non-UTF-8 text", "[documents]") {
  InputError e = error_text("experiment", std::string("{\"laws\": [tru]}"));
  CHECK(e.pointer().empty());
  CHECK_THAT(e.expected(), Catch::StartsWith("valid JSON (parse error at line 1, column"));
  CHECK_THAT(e.expected(), Catch::Contains("(byte "));
  CHECK(e.got() == R"('{"laws": [tru]')");  // the text up to the error
  e = error_text("experiment", std::string(100, ' ') + "{\"laws\"\n: x");
  CHECK(e.got() == "'..." + std::string(29, ' ') + "{\"laws\"\\n: x'");  // the last 40 bytes, on one line
  e = error_text("bounds", std::string(" \n"));
  CHECK_THAT(e.expected(), Catch::StartsWith("valid JSON ("));
  CHECK(e.got() == "an empty text");
  e = error_text("experiment", std::string("{\"name\": \"\xff\xfe\"}"));
  CHECK_THAT(e.expected(), Catch::Contains("UTF-8"));
  CHECK_THAT(e.what(), Catch::Contains("\\xFF"));  // bad bytes shown escaped: messages stay valid UTF-8
  CHECK_THROWS_AS(parse_experiment("1e400", "t.json"), InputError);
  CHECK_THROWS_AS(parse_experiment("{} {}", "t.json"), InputError);
}

TEST_CASE("documents: deep nesting is refused without recursion", "[documents]") {
  const std::size_t depth = 100000;
  InputError e = error_text("experiment", std::string(depth, '['));  // unterminated
  CHECK_THAT(e.expected(), Catch::StartsWith("valid JSON ("));
  e = error_text("experiment", std::string(depth, '[') + std::string(depth, ']'));
  CHECK(e.pointer().empty());
  CHECK(e.expected() == "arrays and objects nested at most 64 deep");
  std::string deep;
  for (std::size_t i = 0; i < depth; ++i) deep += "{\"a\":";
  deep += "1" + std::string(depth, '}');
  CHECK(error_text("bounds", deep).expected() == "arrays and objects nested at most 64 deep");
  // Brackets inside strings are not structure.
  json in = experiment();
  in["description"] = std::string(1000, '[');
  CHECK_NOTHROW(parse_experiment(in.dump(), "t.json"));
}

TEST_CASE("documents: schemas using unsupported features are refused at load", "[documents]") {
  const auto load = [](const std::string& text) { return SchemaSet({{"s.json", text}}); };
  CHECK_THROWS_AS(load(R"({"type": "string", "pattern": "^a"})"), std::logic_error);
  CHECK_THROWS_AS(load(R"({"properties": {"a": {"anyOf": [{"type": "string"}]}}})"), std::logic_error);
  CHECK_THROWS_AS(load(R"({"$ref": "#/definitions/a", "type": "string", "definitions": {"a": {}}})"), std::logic_error);
  CHECK_THROWS_AS(load(R"({"$ref": "#/definitions/missing"})"), std::logic_error);
  CHECK_THROWS_AS(load(R"({"$ref": "#/definitions/a", "definitions": {"a": {"$ref": "#"}}})"), std::logic_error);
  CHECK_THROWS_AS(load(R"({"type": "integer", "default": 1.5})"), std::logic_error);
  CHECK_THROWS_AS(load(R"({"type": "strin"})"), std::logic_error);
  CHECK_THROWS_AS(load(R"({"items": {"definitions": {}}})"), std::logic_error);  // definitions only at a root
  CHECK_THROWS_AS(load("true"), std::logic_error);
  CHECK_THROWS_AS(load("{"), std::logic_error);
  CHECK_NOTHROW(load(R"({"type": "string", "description": "d", "title": "t", "$id": "x", "$schema": "y"})"));
  // Draft 2020-12 spellings and the keywords beside if/then that are not supported.
  CHECK_THROWS_AS(load(R"({"$defs": {"a": {}}})"), std::logic_error);
  CHECK_THROWS_AS(load(R"({"properties": {"a": true}})"), std::logic_error);
  CHECK_THROWS_AS(load(R"({"if": {"const": 1}, "then": {}, "else": {}})"), std::logic_error);
  CHECK_THROWS_AS(load(R"({"if": {"const": 1}})"), std::logic_error);  // no effect without then
  CHECK_THROWS_AS(load(R"({"then": {"const": 1}})"), std::logic_error);
  CHECK_THROWS_AS(load(R"({"allOf": []})"), std::logic_error);
  CHECK_THROWS_AS(load(R"({"exclusiveMinimum": true})"), std::logic_error);  // draft-04's boolean form
  CHECK_THROWS_AS(load(R"({"type": "number", "exclusiveMaximum": 1, "default": 1})"), std::logic_error);
}

TEST_CASE("documents: const, exclusiveMinimum, exclusiveMaximum", "[documents]") {
  const SchemaSet set(Files{{"s.json", R"({"type": "object", "properties": {
      "k": {"const": "report"}, "z": {"const": 2},
      "x": {"type": "number", "exclusiveMinimum": 0, "exclusiveMaximum": 180},
      "i": {"type": "integer", "exclusiveMinimum": -1}}})"}});
  const auto error = [&](const char* text) {
    json doc = json::parse(text);
    try {
      set.validate("s.json", doc, "d.json");
    } catch (const InputError& e) { return std::string(e.what()); }
    return std::string("accepted");
  };
  CHECK(error(R"({"k": "report", "z": 2.0, "x": 1e-300, "i": 0})") == "accepted");  // 2.0 equals 2, as in draft-07
  CHECK(error(R"({"k": "repor"})") == "d.json: at /k: expected \"report\", got \"repor\"");
  CHECK(error(R"({"k": null})") == "d.json: at /k: expected \"report\", got null");
  CHECK(error(R"({"z": true})") == "d.json: at /z: expected 2, got true");  // a boolean is no number
  CHECK(error(R"({"x": 0})") == "d.json: at /x: expected a number > 0, got 0");
  CHECK(error(R"({"x": -0.0})") == "d.json: at /x: expected a number > 0, got -0.0");
  CHECK(error(R"({"x": 180})") == "d.json: at /x: expected a number < 180, got 180");
  CHECK(error(R"({"x": 179.99999})") == "accepted");
  CHECK(error(R"({"i": -1})") == "d.json: at /i: expected an integer > -1, got -1");
}

TEST_CASE("documents: allOf and if/then choose a variant by a field, and report its errors", "[documents]") {
  const SchemaSet set(Files{{"s.json", R"({"type": "object", "required": ["type"],
      "properties": {"type": {"enum": ["a", "b"]}, "common": {"type": "integer", "default": 1}},
      "allOf": [
        {"if": {"properties": {"type": {"const": "a"}}},
         "then": {"required": ["x"], "additionalProperties": false,
                  "properties": {"type": {}, "common": {}, "x": {"type": "number"}, "dx": {"type": "number", "default": 0}}}},
        {"if": {"properties": {"type": {"const": "b"}}},
         "then": {"additionalProperties": false,
                  "properties": {"type": {}, "common": {}, "y": {"type": "string", "default": "why"}}}}]})"}});
  const auto validate = [&](const char* text) {
    json doc = json::parse(text);
    set.validate("s.json", doc, "d.json");
    return doc;
  };
  const auto error = [&](const char* text) {
    try {
      validate(text);
    } catch (const InputError& e) { return std::string(e.what()); }
    return std::string("accepted");
  };
  // Only the matching variant's defaults are filled in (and the common ones).
  CHECK(validate(R"({"type": "a", "x": 1})") == json::parse(R"({"type": "a", "x": 1, "dx": 0, "common": 1})"));
  CHECK(validate(R"({"type": "b"})") == json::parse(R"({"type": "b", "y": "why", "common": 1})"));
  // The variant the discriminator names reports, with its own fields.
  CHECK(error(R"({"type": "a"})") == "d.json: at /x: expected the required field \"x\", got nothing");
  CHECK(error(R"({"type": "a", "x": 1, "y": "s"})") ==
        "d.json: at /y: expected one of the fields common, dx, type, x, got \"y\"");
  CHECK(error(R"({"type": "b", "y": 3})") == "d.json: at /y: expected a string, got 3");
  // The common part is checked first: an unknown discriminator is an enum error.
  CHECK(error(R"({"type": "c"})") == "d.json: at /type: expected one of \"a\", \"b\", got \"c\"");
  CHECK(error(R"({"type": "a", "x": 1, "common": 1.5})") == "d.json: at /common: expected an integer, got 1.5");
  // "if" sees the value as given (before defaults are filled in): a default cannot select a variant,
  // whether the "if" sits beside the default's "properties" or in an allOf or oneOf part.
  for (const char* where : {R"("if": {"required": ["t"]}, "then": {"required": ["u"]})",
                            R"("allOf": [{"if": {"required": ["t"]}, "then": {"required": ["u"]}}])",
                            R"("oneOf": [{"if": {"required": ["t"]}, "then": {"required": ["u"]}}])"}) {
    const SchemaSet by_default(
        Files{{"t.json", std::string(R"({"properties": {"t": {"default": "a"}}, )") + where + "}"}});
    json doc = json::parse("{}");
    CHECK_NOTHROW(by_default.validate("t.json", doc, "d.json"));
    CHECK(doc == json::parse(R"({"t": "a"})"));
    doc = json::parse(R"({"t": "b"})");
    CHECK_THROWS_AS(by_default.validate("t.json", doc, "d.json"), InputError);
  }
}

TEST_CASE("documents: scenes", "[documents]") {
  SECTION("defaults, in the variant the primitive's type names") {
    const json doc = parse_document("scene", scene().dump(), "s.json");
    CHECK(doc["camera"]["fov_axis"] == "horizontal");
    CHECK(doc["camera"]["up"] == json::parse("[0, 0, 1]"));
    CHECK(doc["primitive"] == json::parse(R"({"type": "sphere", "center": [0, 0, 0], "radius": 1, "uv_scale": 1.0})"));
    CHECK(doc["material"] == json::parse(R"({"ndf": "beckmann", "alpha": 1.0, "R": 0.5, "density": 1000})"));
    CHECK(parse_document("scene", doc.dump(), "s.json") == doc);
    json in = scene();
    in["primitive"] = {{"type", "heightfield"}, {"height", {{"amplitude", 0.02}, {"frequency", 4}}}};
    const json hf = parse_document("scene", in.dump(), "s.json")["primitive"];
    CHECK(hf == json::parse(R"({"type": "heightfield", "uv_scale": 1.0, "point": [0, 0, 0], "normal": [0, 0, 1],
                                "tilt_deg": 0, "height": {"amplitude": 0.02, "frequency": 4, "octaves": 3}})"));
    for (const char* name : {"sphere", "plane_90", "plane_25", "heightfield_90", "heightfield_25"}) {
      const std::string file = std::string("python/glintlab/data/scenes/") + name + ".json";
      CHECK_NOTHROW(parse_document("scene", read_file(file), file));
    }
  }
  SECTION("a bad scene names the pointer and what was expected") {
    json in = scene();
    in["camera"]["fov_deg"] = 0;
    InputError e = error_of("scene", in);
    CHECK(std::string(e.what()) == "t.json: at /camera/fov_deg: expected a number > 0, got 0");
    in["camera"]["fov_deg"] = 180;
    CHECK(error_of("scene", in).expected() == "a number < 180");
    in["camera"]["fov_deg"] = "wide";
    CHECK_THAT(error_of("scene", in).expected(), Catch::StartsWith("the full field of view along fov_axis in degrees"));
    in = scene();
    in["primitive"].erase("radius");
    e = error_of("scene", in);
    CHECK(e.pointer() == "/primitive/radius");
    CHECK(e.expected() == "the required field \"radius\"");
    in = scene();
    in["primitive"]["normal"] = {0, 0, 1};  // a plane's field on a sphere
    e = error_of("scene", in);
    CHECK(e.pointer() == "/primitive/normal");
    CHECK(e.expected() == "one of the fields center, radius, type, uv_scale");
    in = scene();
    in["primitive"]["type"] = "torus";
    CHECK(error_of("scene", in).expected() == "one of \"plane\", \"sphere\", \"heightfield\"");
    in = scene();
    in["primitive"] = {{"type", "heightfield"}, {"height", {{"amplitude", 0.02}, {"frequency", 4}, {"octaves", 9}}}};
    e = error_of("scene", in);
    CHECK(e.pointer() == "/primitive/height/octaves");
    CHECK(e.expected() == "an integer <= 8");
    in = scene();
    in["light"] = {{"type", "directional"}, {"position", {0, 0, 1}}};
    e = error_of("scene", in);
    CHECK(e.pointer() == "/light/direction");
    CHECK(e.expected() == "the required field \"direction\"");
    in = scene();
    in["material"]["R"] = 1.5;
    CHECK(std::string(error_of("scene", in).what()) == "t.json: at /material/R: expected a number <= 1, got 1.5");
    in = scene();
    in["camera"]["position"][1] = "x";
    CHECK(error_of("scene", in).pointer() == "/camera/position/1");
    CHECK_THAT(error_text("scene", "[]").expected(), Catch::StartsWith("a scene, an object {camera, primitive"));
  }
}

TEST_CASE("documents: report configurations", "[documents]") {
  const json doc = parse_document("report", report().dump(), "r.json");
  CHECK(doc == report());  // no defaults: the sections' own parameters apply
  CHECK_NOTHROW(parse_document("report", read_file("python/glintlab/data/report/default.json"), "default.json"));
  json in = report();
  in["kind"] = "experiment";
  InputError e = error_of("report", in);
  CHECK(std::string(e.what()) == "t.json: at /kind: expected \"report\", got \"experiment\"");
  in = report();
  in["sections"][0]["parms"] = json::object();
  e = error_of("report", in);
  CHECK(e.pointer() == "/sections/0/parms");
  CHECK(e.expected() == "one of the fields name, params, quick");
  in = report();
  in["sections"] = json::array();
  CHECK(error_of("report", in).expected() == "an array of at least 1 item");
  in = report();
  in["sections"][0]["params"] = json::array();
  e = error_of("report", in);
  CHECK(e.pointer() == "/sections/0/params");
  CHECK(e.expected() == "an object of the section's parameters");
  in = report();
  in["seed"] = 18446744073709551615ULL;
  CHECK_NOTHROW(parse_document("report", in.dump(), "r.json"));
  in["seed"] = -1;
  CHECK(error_of("report", in).expected() == "an integer >= 0");
}

TEST_CASE("documents: pipelines", "[documents]") {
  // A stage's kind picks its fields (allOf and if/then); bounds reuse the bounds schema's regime, which
  // reuses the experiment schema's axes: three files resolved by name.
  const json in = json::parse(R"({"stages": [{"id": "l", "kind": "law", "law": "gated", "range": {"n": [8]},
                                                "bounds": [{"metric": "tv"}]}]})");
  const json doc = parse_document("pipeline", in.dump(), "p.json");
  CHECK(doc["seed"] == 1);
  CHECK(doc["margin"]["relative"] == 0.25);
  CHECK(doc["stages"][0]["samples"] == 20000);
  CHECK(doc["stages"][0]["range"]["p"] == "standard");
  for (const char* name : {"db23_paper", "db23_shader_48", "zk16", "kpt25", "wwh18_filtered"})
    CHECK_NOTHROW(
        parse_document("pipeline", read_file(std::string("python/glintlab/data/pipelines/") + name + ".json"), name));
  json bad = in;
  bad["stages"][0]["blend"] = "distributed";
  InputError e = error_of("pipeline", bad);
  CHECK(e.pointer() == "/stages/0/blend");
  bad = in;
  bad["stages"][0]["range"]["n"] = json::array();
  CHECK(error_of("pipeline", bad).pointer() == "/stages/0/range/n");
  bad = in;
  bad["stages"][0]["kind"] = "lod";
  CHECK(error_of("pipeline", bad).pointer() == "/stages/0/kind");
}

TEST_CASE("documents: a schema set resolves references across files by name", "[documents]") {
  const SchemaSet set(
      {{"a.json", R"({"type": "object", "properties": {"x": {"$ref": "b.json#/definitions/pair"},
                                      "y": {"$ref": "https://host/dir/b.json#/definitions/pair", "default": [1, "z"]}}})"},
       {"b.json",
        R"({"definitions": {"pair": {"type": "array", "items": [{"type": "integer"}, {"type": "string"}]}}})"}});
  json doc = json::parse(R"({"x": [1, "a", null]})");  // items beyond the tuple are free (draft-07)
  set.validate("a.json", doc, "d.json");
  CHECK(doc["y"] == json::parse(R"([1, "z"])"));
  doc = json::parse(R"({"x": ["a", 1]})");
  try {
    set.validate("a.json", doc, "d.json");
    FAIL("accepted");
  } catch (const InputError& e) { CHECK(std::string(e.what()) == "d.json: at /x/0: expected an integer, got \"a\""); }
  CHECK_THROWS_AS(set.validate("c.json", doc, "d.json"), std::logic_error);
}

TEST_CASE("documents: embedded schemas and the standard grid match the data files", "[documents]") {
  using glintlab::validation::schema_text;
  CHECK(json::parse(schema_text("experiment")) ==
        json::parse(read_file("python/glintlab/data/schema/experiment.schema.json")));
  CHECK(json::parse(schema_text("bounds")) == json::parse(read_file("python/glintlab/data/schema/bounds.schema.json")));
  CHECK(json::parse(schema_text("scene")) == json::parse(read_file("python/glintlab/data/schema/scene.schema.json")));
  CHECK(json::parse(schema_text("report")) == json::parse(read_file("python/glintlab/data/schema/report.schema.json")));
  CHECK(json::parse(schema_text("pipeline")) ==
        json::parse(read_file("python/glintlab/data/schema/pipeline.schema.json")));
  CHECK_THROWS_AS(schema_text("nope"), std::invalid_argument);
  const json grid = json::parse(read_file("python/glintlab/data/grids/standard.json"));
  CHECK(grid["n"].size() == glintlab::validation::standard_n_count);
  CHECK(grid["p"].size() == glintlab::validation::standard_p_count);
}

TEST_CASE("documents: got renders long values briefly", "[documents]") {
  using glintlab::validation::render;
  CHECK(render(json::parse("[1, 2]")) == "[1,2]");
  json big = json::array();
  for (int i = 0; i < 100000; ++i) big.push_back(i);
  CHECK(render(big).size() == 60);
  CHECK(render(std::string(1000, 'x')).size() == 60);
  CHECK(render(std::string(200, '\xc3')).size() <= 60);  // ill-formed UTF-8 (never from the parser) is replaced
  std::string accents;
  for (int i = 0; i < 100; ++i) accents += "\xc3\xa9";
  const std::string cut = render(accents);
  CHECK(cut.substr(cut.size() - 3) == "...");
  CHECK((static_cast<unsigned char>(cut[cut.size() - 4]) & 0xC0) != 0xC0);  // no lead byte left dangling
}
