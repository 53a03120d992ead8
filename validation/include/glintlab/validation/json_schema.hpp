// A JSON Schema (draft-07) validator for exactly the keywords glintlab's own schemas use
// (python/glintlab/data/schema/*.schema.json). Debian packages no C++ validator, and a small one lets the error
// messages name the JSON pointer and what was expected in the user's terms. A schema that uses any
// other keyword is rejected when loaded (std::logic_error), so it can never be silently ignored.
// Supported: type, enum, const, properties, required, additionalProperties (false or a schema), items
// (a schema or a tuple), minItems, maxItems, minLength, maxLength, minimum, maximum, exclusiveMinimum,
// exclusiveMaximum (numbers, as in draft-07), oneOf, allOf, if with then (no else), $ref, definitions
// (at a root) and default; $schema, $id, title and description are annotations (a description is the
// "expected" text when a value has the wrong type, so schemas phrase it as what a value must be).
#pragma once

#include <cstddef>
#include <memory>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace glintlab::validation {

// Bad input. what() is "<source>: at <pointer>: expected <expected>, got <got>", the root pointer ""
// being shown as "/".
class InputError : public std::invalid_argument {
 public:
  InputError(std::string source, std::string pointer, std::string expected, std::string got);
  const std::string& source() const noexcept { return source_; }
  const std::string& pointer() const noexcept { return pointer_; }
  const std::string& expected() const noexcept { return expected_; }
  const std::string& got() const noexcept { return got_; }

 private:
  std::string source_, pointer_, expected_, got_;
};

// Deepest nesting of arrays and objects accepted. Real documents need about 8 levels; the limit keeps
// every recursive operation on a parsed value (copy, compare, dump) far from the stack's end.
inline constexpr int max_nesting = 64;

// Parses JSON text. Invalid JSON (including ill-formed UTF-8) and nesting deeper than max_nesting
// are InputErrors at the root pointer.
nlohmann::json parse_json(std::string_view text, const std::string& source);

// A short (about 60 characters, never cut inside a UTF-8 character) rendering of a value.
std::string render(const nlohmann::json& value);

// JSON pointer token for an object key ("~" -> "~0", "/" -> "~1").
std::string pointer_token(std::string_view key);

class SchemaSet {
 public:
  // (file name, schema text) pairs. "$ref": "other.schema.json#/definitions/x" resolves by file name
  // among them, "#/definitions/x" within the same file. Throws std::logic_error on a schema this
  // validator does not support completely.
  explicit SchemaSet(const std::vector<std::pair<std::string, std::string>>& files);
  ~SchemaSet();
  SchemaSet(SchemaSet&&) noexcept;
  SchemaSet& operator=(SchemaSet&&) noexcept;

  // Validates `doc` against the root of schema `file` and fills in every default (recursively,
  // including inside the oneOf branch that matched). Numbers with an integral value where only an
  // integer is allowed become integers (2.0 -> 2). Throws InputError naming `source`.
  void validate(const std::string& file, nlohmann::json& doc, const std::string& source) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace glintlab::validation
