#include "glintlab/validation/json_schema.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <deque>
#include <map>
#include <optional>

namespace glintlab::validation {

using json = nlohmann::json;

InputError::InputError(std::string source, std::string pointer, std::string expected, std::string got)
    : std::invalid_argument(source + ": at " + (pointer.empty() ? "/" : pointer) + ": expected " + expected + ", got " +
                            got),
      source_(std::move(source)), pointer_(std::move(pointer)), expected_(std::move(expected)), got_(std::move(got)) {}

namespace {

// Length of a well-formed UTF-8 sequence starting at s[i], 0 if ill-formed (overlong forms,
// surrogates and code points above U+10FFFF included).
std::size_t utf8_length(std::string_view s, std::size_t i) {
  const auto b = [&](std::size_t k) { return static_cast<unsigned char>(s[k]); };
  const unsigned c = b(i);
  if (c < 0x80) return 1;
  std::size_t n = c >= 0xF0 ? 4 : c >= 0xE0 ? 3 : c >= 0xC2 ? 2 : 0;
  if (n == 0 || c > 0xF4 || i + n > s.size()) return 0;
  for (std::size_t k = 1; k < n; ++k)
    if ((b(i + k) & 0xC0) != 0x80) return 0;
  if ((c == 0xE0 && b(i + 1) < 0xA0) || (c == 0xED && b(i + 1) >= 0xA0) || (c == 0xF0 && b(i + 1) < 0x90) ||
      (c == 0xF4 && b(i + 1) >= 0x90))
    return 0;
  return n;
}

// Messages end up in Python strings, which must be valid UTF-8, and on one line: bad bytes and
// control characters become "\xNN" ("\n", "\t", "\r").
std::string clean_utf8(std::string_view s) {
  std::string out;
  for (std::size_t i = 0; i < s.size();) {
    const std::size_t n = utf8_length(s, i);
    const auto c = static_cast<unsigned char>(s[i]);
    if (n > 0 && c >= 0x20 && c != 0x7F) {
      out.append(s, i, n);
      i += n;
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02X", c);
      out += c == '\n' ? "\\n" : c == '\t' ? "\\t" : c == '\r' ? "\\r" : hex;
      ++i;
    }
  }
  return out;
}

constexpr std::size_t render_limit = 60;

// Stops as soon as the budget is spent, so rendering a huge array costs no more than a short one.
void render_into(const json& v, std::string& out) {
  if (out.size() > render_limit) return;
  if (v.is_array() || v.is_object()) {
    out += v.is_array() ? '[' : '{';
    bool first = true;
    for (auto it = v.begin(); it != v.end() && out.size() <= render_limit; ++it, first = false) {
      if (!first) out += ',';
      if (v.is_object()) out += json(it.key()).dump(-1, ' ', false, json::error_handler_t::replace) + ':';
      render_into(*it, out);
    }
    out += v.is_array() ? ']' : '}';
  } else if (v.is_string() && v.get_ref<const std::string&>().size() > 2 * render_limit) {
    render_into(json(v.get_ref<const std::string&>().substr(0, 2 * render_limit)), out);
  } else {
    out += v.dump(-1, ' ', false, json::error_handler_t::replace);
  }
}

std::size_t code_points(const std::string& s) {
  return static_cast<std::size_t>(std::count_if(s.begin(), s.end(), [](char c) { return (c & 0xC0) != 0x80; }));
}

// Every JSON number (64-bit integers and doubles) is exact in x87 long double, so comparisons between
// integers near 2^53..2^64 and double limits are exact.
long double as_long_double(const json& v) {
  if (v.is_number_unsigned()) return static_cast<long double>(v.get<std::uint64_t>());
  if (v.is_number_integer()) return static_cast<long double>(v.get<std::int64_t>());
  return static_cast<long double>(v.get<double>());
}

enum : unsigned { t_null = 1, t_boolean = 2, t_integer = 4, t_number = 8, t_string = 16, t_array = 32, t_object = 64 };
struct TypeName {
  const char* name;
  unsigned bit;
  const char* phrase;
};
constexpr TypeName type_names[] = {{"integer", t_integer, "an integer"},
                                   {"number", t_number, "a number"},
                                   {"string", t_string, "a string"},
                                   {"boolean", t_boolean, "a boolean"},
                                   {"array", t_array, "an array"},
                                   {"object", t_object, "an object"},
                                   {"null", t_null, "null"}};

unsigned value_types(const json& v) {
  switch (v.type()) {
    case json::value_t::null: return t_null;
    case json::value_t::boolean: return t_boolean;
    case json::value_t::number_integer:
    case json::value_t::number_unsigned: return t_integer | t_number;
    case json::value_t::number_float: {
      const double x = v.get<double>();
      return std::isfinite(x) && std::trunc(x) == x ? t_integer | t_number : t_number;
    }
    case json::value_t::string: return t_string;
    case json::value_t::array: return t_array;
    case json::value_t::object: return t_object;
    default: return 0;
  }
}

std::string type_text(unsigned types) {
  if (types & t_number) types &= ~t_integer;
  std::string out;
  for (const TypeName& t : type_names)
    if (types & t.bit) out += (out.empty() ? "" : " or ") + std::string(t.phrase);
  return out;
}

std::string plural(std::size_t n, const char* what) { return std::to_string(n) + " " + what + (n == 1 ? "" : "s"); }

struct Node {
  std::string where;  // file#pointer, for messages about the schema itself
  std::string description;
  const json* default_value = nullptr;
  unsigned types = 0;  // 0: any type
  const json* enumeration = nullptr;
  const json* constant = nullptr;
  std::map<std::string, const Node*> properties;
  std::vector<std::string> required;
  bool additional_allowed = true;
  const Node* additional = nullptr;
  const Node* items = nullptr;
  std::vector<const Node*> tuple;
  std::optional<std::size_t> min_items, max_items, min_length, max_length;
  const json* minimum = nullptr;
  const json* maximum = nullptr;
  const json* exclusive_minimum = nullptr;
  const json* exclusive_maximum = nullptr;
  std::vector<const Node*> one_of;
  std::vector<const Node*> all_of;
  const Node* if_node = nullptr;  // with then_node: "if" holds => "then" must hold
  const Node* then_node = nullptr;
  std::string ref;
  const Node* target = nullptr;
};

// A failed check. `progress` ranks how far validation got before failing (3 per level of the
// document, then type < required < anything else at one level); oneOf reports the failure of the
// branch that got furthest, which is the branch the user meant.
struct Failure {
  std::string pointer, expected, got;
  int progress;
};
using Result = std::optional<Failure>;

const json* default_of(const Node* n) {
  for (; n; n = n->target)
    if (n->default_value) return n->default_value;
  return nullptr;
}

}  // namespace

std::string render(const json& value) {
  std::string out;
  render_into(value, out);
  if (out.size() > render_limit) {
    std::size_t cut = render_limit - 3;
    while (cut > 0 && (static_cast<unsigned char>(out[cut]) & 0xC0) == 0x80) --cut;  // not inside a character
    out.resize(cut);
    out += "...";
  }
  return out;
}

std::string pointer_token(std::string_view key) {
  std::string out;
  for (char c : key) out += c == '~' ? "~0" : c == '/' ? "~1" : std::string(1, c);
  return out;
}

json parse_json(std::string_view text, const std::string& source) {
  json doc;
  try {
    doc = json::parse(text.begin(), text.end());
  } catch (const json::exception& e) {
    // "[json.exception.parse_error.101] parse error at line 1, column 5: ...; last read: 'tru,'": keep
    // the message, but show the text before the error position ourselves (the last read token may
    // be long, and is empty for some errors).
    std::string message = e.what();
    if (const auto p = message.find("] "); p != std::string::npos) message.erase(0, p + 2);
    if (const auto p = message.find("; last read: '"); p != std::string::npos) {
      const auto q = message.find("'; ", p + 14);
      message.erase(p, q == std::string::npos ? std::string::npos : q + 1 - p);
    }
    std::string got = "invalid JSON";
    if (const auto* pe = dynamic_cast<const json::parse_error*>(&e)) {
      message += " (byte " + std::to_string(pe->byte) + ")";
      const std::size_t end = std::min(pe->byte, text.size());
      std::size_t start = end > 40 ? end - 40 : 0;
      while (start < end && (static_cast<unsigned char>(text[start]) & 0xC0) == 0x80) ++start;
      got = (start > 0 ? "'..." : "'") + clean_utf8(text.substr(start, end - start)) + "'";
      if (text.find_first_not_of(" \t\r\n") == std::string_view::npos) got = "an empty text";
    }
    throw InputError(source, "", "valid JSON (" + clean_utf8(message) + ")", got);
  }
  // nlohmann parses and destroys without recursion, but copies, comparisons and dumps recurse: bound
  // the depth once here. The text is valid JSON, so brackets outside strings are structure.
  int depth = 0;
  bool in_string = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      if (c == '\\')
        ++i;
      else if (c == '"')
        in_string = false;
    } else if (c == '"') {
      in_string = true;
    } else if (c == '[' || c == '{') {
      if (++depth > max_nesting)
        throw InputError(source, "", "arrays and objects nested at most " + std::to_string(max_nesting) + " deep",
                         "deeper nesting (at byte " + std::to_string(i + 1) + ")");
    } else if (c == ']' || c == '}') {
      --depth;
    }
  }
  return doc;
}

struct SchemaSet::Impl {
  std::map<std::string, json> files;  // node-based: Node points into these values
  std::deque<Node> nodes;
  std::map<std::string, Node*> index;  // "file#" and "file#/definitions/name"

  [[noreturn]] static void bad(const std::string& where, const std::string& what) {
    throw std::logic_error("schema " + where + ": " + what);
  }

  static std::size_t count(const json& v, const std::string& where) {
    if (!v.is_number_unsigned()) bad(where, "expected a non-negative integer");
    return v.get<std::size_t>();
  }

  Node* compile(const json& s, const std::string& where, bool root) {
    if (!s.is_object()) bad(where, "a schema must be an object");
    Node& n = nodes.emplace_back();
    n.where = where;
    for (const auto& [key, v] : s.items()) {
      const std::string at = where + "/" + pointer_token(key);
      if (key == "$schema" || key == "$id" || key == "title" || (key == "definitions" && root)) {
        // annotations; definitions are compiled by the constructor
      } else if (key == "description") {
        if (!v.is_string()) bad(at, "expected a string");
        n.description = v.get<std::string>();
      } else if (key == "default") {
        n.default_value = &v;
      } else if (key == "type") {
        for (const json& t : v.is_array() ? v : json::array({v})) {
          const auto it = std::find_if(std::begin(type_names), std::end(type_names),
                                       [&](const TypeName& tn) { return t.is_string() && t == tn.name; });
          if (it == std::end(type_names)) bad(at, "unknown type " + t.dump());
          n.types |= it->bit;
        }
      } else if (key == "enum") {
        if (!v.is_array() || v.empty()) bad(at, "expected a non-empty array");
        n.enumeration = &v;
      } else if (key == "const") {
        n.constant = &v;
      } else if (key == "properties") {
        if (!v.is_object()) bad(at, "expected an object");
        for (const auto& [name, sub] : v.items())
          n.properties[name] = compile(sub, at + "/" + pointer_token(name), false);
      } else if (key == "required") {
        if (!v.is_array()) bad(at, "expected an array");
        for (const json& r : v) {
          if (!r.is_string()) bad(at, "expected strings");
          n.required.push_back(r.get<std::string>());
        }
      } else if (key == "additionalProperties") {
        if (v.is_boolean())
          n.additional_allowed = v.get<bool>();
        else
          n.additional = compile(v, at, false);
      } else if (key == "items") {
        if (v.is_array()) {
          for (std::size_t i = 0; i < v.size(); ++i)
            n.tuple.push_back(compile(v[i], at + "/" + std::to_string(i), false));
        } else {
          n.items = compile(v, at, false);
        }
      } else if (key == "minItems") {
        n.min_items = count(v, at);
      } else if (key == "maxItems") {
        n.max_items = count(v, at);
      } else if (key == "minLength") {
        n.min_length = count(v, at);
      } else if (key == "maxLength") {
        n.max_length = count(v, at);
      } else if (key == "minimum" || key == "maximum") {
        if (!v.is_number()) bad(at, "expected a number");
        (key == "minimum" ? n.minimum : n.maximum) = &v;
      } else if (key == "exclusiveMinimum" || key == "exclusiveMaximum") {
        if (!v.is_number()) bad(at, "expected a number (draft-07: the bound itself)");
        (key == "exclusiveMinimum" ? n.exclusive_minimum : n.exclusive_maximum) = &v;
      } else if (key == "oneOf") {
        if (!v.is_array() || v.empty()) bad(at, "expected a non-empty array");
        for (std::size_t i = 0; i < v.size(); ++i)
          n.one_of.push_back(compile(v[i], at + "/" + std::to_string(i), false));
      } else if (key == "allOf") {
        if (!v.is_array() || v.empty()) bad(at, "expected a non-empty array");
        for (std::size_t i = 0; i < v.size(); ++i)
          n.all_of.push_back(compile(v[i], at + "/" + std::to_string(i), false));
      } else if (key == "if" || key == "then") {
        (key == "if" ? n.if_node : n.then_node) = compile(v, at, false);
      } else if (key == "$ref") {
        if (!v.is_string()) bad(at, "expected a string");
        n.ref = v.get<std::string>();
      } else {
        bad(at, "unsupported keyword \"" + key + "\"");
      }
    }
    // "if" without "then" has no effect, "then" without "if" is ignored ("else" is not supported).
    if (!n.if_node != !n.then_node) bad(where, n.if_node ? "\"if\" without \"then\"" : "\"then\" without \"if\"");
    // Draft-07 ignores every keyword beside $ref: refuse them rather than let them look effective.
    if (!n.ref.empty())
      for (const auto& [key, v] : s.items())
        if (key != "$ref" && key != "description" && key != "default" && key != "title")
          bad(where, "\"" + key + "\" beside \"$ref\" would be ignored");
    return &n;
  }

  explicit Impl(const std::vector<std::pair<std::string, std::string>>& texts) {
    for (const auto& [name, text] : texts) {
      try {
        files[name] = json::parse(text);
      } catch (const json::exception& e) { bad(name, e.what()); }
    }
    for (const auto& [name, root] : files) {
      if (root.is_object() && root.contains("definitions")) {
        const json& defs = root["definitions"];
        if (!defs.is_object()) bad(name + "#/definitions", "expected an object");
        for (const auto& [def, sub] : defs.items())
          index[name + "#/definitions/" + pointer_token(def)] =
              compile(sub, name + "#/definitions/" + pointer_token(def), false);
      }
      index[name + "#"] = compile(root, name + "#", true);
    }
    for (Node& n : nodes) {
      if (n.ref.empty()) continue;
      const auto hash = n.ref.find('#');
      std::string file = n.ref.substr(0, hash);
      if (const auto slash = file.rfind('/'); slash != std::string::npos) file.erase(0, slash + 1);  // a URL
      if (file.empty()) file = n.where.substr(0, n.where.find('#'));
      const std::string key = file + (hash == std::string::npos ? "#" : n.ref.substr(hash));
      const auto it = index.find(key);
      if (it == index.end()) bad(n.where, "cannot resolve \"$ref\": \"" + n.ref + "\"");
      n.target = it->second;
    }
    for (const Node& n : nodes) {
      const Node* t = &n;
      for (std::size_t steps = 0; t; t = t->target)
        if (++steps > nodes.size()) bad(n.where, "\"$ref\" cycle");
    }
    // A default must itself be valid: it is inserted into documents as if the user had written it.
    for (const Node& n : nodes) {
      if (!n.default_value) continue;
      json copy = *n.default_value;
      if (const Result f = check(n, copy, "", 0)) bad(n.where + "/default", "invalid default: expected " + f->expected);
    }
  }

  static std::string enum_text(const json& values) {
    std::string out = values.size() > 1 ? "one of " : "";
    for (std::size_t i = 0; i < values.size(); ++i) out += (i ? ", " : "") + values[i].dump();
    return out;
  }

  static std::string number_text(const Node& n) { return n.types == t_integer ? "an integer" : "a number"; }

  // if_holds: this node's "if", decided by the caller (the node whose allOf or oneOf holds this one)
  // before it filled in any default.
  Result check(const Node& start, json& v, const std::string& ptr, int depth,
               std::optional<bool> if_holds = std::nullopt) const {
    const Node* np = &start;
    while (np->target) np = np->target;  // $ref: its siblings are annotations (enforced by compile)
    const Node& n = *np;
    const int level = 3 * depth;
    const auto fail = [&](std::string expected, std::string got) {
      return Failure{ptr, std::move(expected), std::move(got), level + 2};
    };

    const unsigned vt = value_types(v);
    if (n.types && !(n.types & vt))
      return Failure{ptr, n.description.empty() ? type_text(n.types) : n.description, render(v), level};
    // 2.0 where only integers are allowed is the integer 2 (as in draft-07); store it as one.
    if ((n.types & t_integer) && !(n.types & t_number) && v.is_number_float()) {
      const double x = v.get<double>();
      if (x >= -9.2e18 && x <= 9.2e18) v = static_cast<std::int64_t>(x);
    }
    // "if" sees the value as given, not with defaults filled in: it is decided now, on a copy (checking
    // fills defaults), for this node and for the parts of its allOf and oneOf.
    const auto decide = [&](const Node& c) -> std::optional<bool> {
      if (!c.if_node) return std::nullopt;
      json trial = v;
      return !check(*c.if_node, trial, ptr, depth);
    };
    const bool then_applies = n.if_node && (if_holds ? *if_holds : *decide(n));
    std::vector<std::optional<bool>> all_of_if, one_of_if;
    for (auto [parts, decided] : {std::pair{&n.all_of, &all_of_if}, std::pair{&n.one_of, &one_of_if}})
      for (const Node* part : *parts) {
        while (part->target) part = part->target;
        decided->push_back(decide(*part));
      }
    if (n.enumeration && std::find(n.enumeration->begin(), n.enumeration->end(), v) == n.enumeration->end())
      return fail(enum_text(*n.enumeration), render(v));
    if (n.constant && v != *n.constant) return fail(n.constant->dump(), render(v));

    if (v.is_string()) {
      const std::size_t len = code_points(v.get_ref<const std::string&>());
      if (n.min_length && len < *n.min_length)
        return fail(
            *n.min_length == 1 ? "a non-empty string" : "a string of at least " + plural(*n.min_length, "character"),
            render(v));
      if (n.max_length && len > *n.max_length)
        return fail("a string of at most " + plural(*n.max_length, "character"), render(v));
    }
    if (v.is_number()) {
      if (n.minimum && as_long_double(v) < as_long_double(*n.minimum))
        return fail(number_text(n) + " >= " + n.minimum->dump(), render(v));
      if (n.maximum && as_long_double(v) > as_long_double(*n.maximum))
        return fail(number_text(n) + " <= " + n.maximum->dump(), render(v));
      if (n.exclusive_minimum && as_long_double(v) <= as_long_double(*n.exclusive_minimum))
        return fail(number_text(n) + " > " + n.exclusive_minimum->dump(), render(v));
      if (n.exclusive_maximum && as_long_double(v) >= as_long_double(*n.exclusive_maximum))
        return fail(number_text(n) + " < " + n.exclusive_maximum->dump(), render(v));
    }

    if (v.is_array()) {
      const bool exact = n.min_items && n.max_items && *n.min_items == *n.max_items;
      if (n.min_items && v.size() < *n.min_items)
        return fail((exact ? "an array of exactly " : "an array of at least ") + plural(*n.min_items, "item"),
                    render(v));
      if (n.max_items && v.size() > *n.max_items)
        return fail((exact ? "an array of exactly " : "an array of at most ") + plural(*n.max_items, "item"),
                    render(v));
      for (std::size_t i = 0; i < v.size(); ++i) {
        const Node* item = n.items ? n.items : i < n.tuple.size() ? n.tuple[i] : nullptr;
        if (item)
          if (Result f = check(*item, v[i], ptr + "/" + std::to_string(i), depth + 1)) return f;
      }
    }

    if (v.is_object()) {
      for (const std::string& key : n.required)
        if (!v.contains(key))
          return Failure{ptr + "/" + pointer_token(key), "the required field \"" + key + "\"", "nothing", level + 1};
      if (!n.additional_allowed) {
        for (const auto& [key, value] : v.items()) {
          if (n.properties.count(key)) continue;
          std::string fields;
          for (const auto& [name, sub] : n.properties) fields += (fields.empty() ? "" : ", ") + name;
          return Failure{ptr + "/" + pointer_token(key),
                         (n.properties.size() == 1 ? "the only field " : "one of the fields ") + fields,
                         render(json(key)), level + 2};
        }
      }
      for (auto it = v.begin(); it != v.end(); ++it) {
        const auto p = n.properties.find(it.key());
        const Node* sub = p != n.properties.end() ? p->second : n.additional;
        if (sub)
          if (Result f = check(*sub, *it, ptr + "/" + pointer_token(it.key()), depth + 1)) return f;
      }
      for (const auto& [key, sub] : n.properties) {
        if (v.contains(key)) continue;
        if (const json* d = default_of(sub)) {
          json filled = *d;
          check(*sub, filled, ptr + "/" + pointer_token(key), depth + 1);  // fills nested defaults; valid (constructor)
          v[key] = std::move(filled);
        }
      }
    }

    if (!n.one_of.empty()) {
      std::optional<json> matched;
      int matches = 0;
      std::vector<Failure> failures;
      for (std::size_t i = 0; i < n.one_of.size(); ++i) {
        json trial = v;
        if (Result f = check(*n.one_of[i], trial, ptr, depth, one_of_if[i])) {
          failures.push_back(std::move(*f));
        } else if (++matches == 1) {
          matched = std::move(trial);
        }
      }
      const std::string what = n.description.empty() ? "one of the allowed forms" : n.description;
      if (matches > 1) return fail(what + " (this value fits more than one form)", render(v));
      if (matches == 1) {
        v = std::move(*matched);
      } else {
        int best = -1, ties = 0;
        const Failure* pick = nullptr;
        for (const Failure& f : failures) {
          if (f.progress > best) best = f.progress, ties = 0, pick = &f;
          if (f.progress == best) ++ties;
        }
        if (ties == 1) return *pick;
        return Failure{ptr, what, render(v), best};
      }
    }

    // allOf and if/then apply to the value in place: each fills its own defaults. A variant chosen by
    // "if" (a discriminating field) reports its own errors, with the fields it allows.
    for (std::size_t i = 0; i < n.all_of.size(); ++i)
      if (Result f = check(*n.all_of[i], v, ptr, depth, all_of_if[i])) return f;
    if (then_applies)
      if (Result f = check(*n.then_node, v, ptr, depth)) return f;
    return std::nullopt;
  }
};

SchemaSet::SchemaSet(const std::vector<std::pair<std::string, std::string>>& files)
    : impl_(std::make_unique<Impl>(files)) {}
SchemaSet::~SchemaSet() = default;
SchemaSet::SchemaSet(SchemaSet&&) noexcept = default;
SchemaSet& SchemaSet::operator=(SchemaSet&&) noexcept = default;

void SchemaSet::validate(const std::string& file, json& doc, const std::string& source) const {
  const auto it = impl_->index.find(file + "#");
  if (it == impl_->index.end()) throw std::logic_error("no schema named " + file);
  if (Result f = impl_->check(*it->second, doc, "", 0))
    throw InputError(source, std::move(f->pointer), std::move(f->expected), std::move(f->got));
}

}  // namespace glintlab::validation
