// glintlab's input documents: experiments (laws over an (n, p) grid, compared by metrics), error
// bounds (limits a renderer's CI gates on), scenes (glintlab profile / advise) and report
// configurations (glintlab report). Each is JSON checked against its schema
// (python/glintlab/data/schema/*.schema.json, embedded at build time); experiments and bounds then by
// the rules a schema cannot state (those of scenes and reports run in Python, in the same format).
#pragma once

#include <cstddef>
#include <nlohmann/json.hpp>
#include <string>
#include <string_view>

#include "glintlab/validation/json_schema.hpp"

namespace glintlab::validation {

// Sizes of the axes of python/glintlab/data/grids/standard.json ("standard" in a grid).
inline constexpr std::size_t standard_n_count = 51;
inline constexpr std::size_t standard_p_count = 47;
// Largest experiment: laws x n values x p values.
inline constexpr std::size_t max_experiment_rows = 10'000'000;

// Parse, validate and normalize: the returned document has every default filled in. Laws given as
// strings stay strings. Throws InputError ("<source>: at <pointer>: expected ..., got ...").
nlohmann::json parse_experiment(std::string_view text, const std::string& source);
nlohmann::json parse_bounds(std::string_view text, const std::string& source);
nlohmann::json parse_scene(std::string_view text, const std::string& source);
nlohmann::json parse_report(std::string_view text, const std::string& source);
nlohmann::json parse_pipeline(std::string_view text, const std::string& source);
// kind "experiment", "bounds", "scene", "report" or "pipeline" (std::invalid_argument otherwise).
nlohmann::json parse_document(const std::string& kind, std::string_view text, const std::string& source);

// The embedded schema text; name "experiment", "bounds", "scene", "report" or "pipeline" (std::invalid_argument
// otherwise).
const std::string& schema_text(const std::string& name);

}  // namespace glintlab::validation
