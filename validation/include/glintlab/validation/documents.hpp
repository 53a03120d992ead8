// glintlab's input documents: experiments (laws over an (n, p) grid, compared by metrics) and error
// bounds (limits a renderer's CI gates on). Each is JSON checked against its schema
// (python/glintlab/data/schema/*.schema.json, embedded at build time) and then by the rules a schema cannot state.
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
// kind "experiment" or "bounds" (std::invalid_argument otherwise).
nlohmann::json parse_document(const std::string& kind, std::string_view text, const std::string& source);

// The embedded schema text; name "experiment" or "bounds" (std::invalid_argument otherwise).
const std::string& schema_text(const std::string& name);

}  // namespace glintlab::validation
