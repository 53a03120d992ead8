// The C++ error vocabulary (glintlab/base/errors.hpp): one message per shape of bad input.
#include <catch2/catch.hpp>

#include <array>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "glintlab/base/errors.hpp"
#include "glintlab/counting/law.hpp"
#include "glintlab/stats/metrics.hpp"

using namespace glintlab;
using Catch::Equals;
using Catch::StartsWith;

namespace {
template <class F>
std::string message_of(F f) {
  try {
    f();
  } catch (const std::invalid_argument& e) { return e.what(); }
  return "(no exception)";
}
enum class Colour { kRed, kGreen };
constexpr std::pair<std::string_view, Colour> kColours[] = {{"red", Colour::kRed}, {"green", Colour::kGreen}};
}  // namespace

TEST_CASE("check_length: one value or one per row, else one message", "[errors]") {
  CHECK_NOTHROW(check_length("f", "p", 1, 7));
  CHECK_NOTHROW(check_length("f", "p", 7, 7));
  CHECK_NOTHROW(check_length("f", "p", 0, 0));
  CHECK_THAT(message_of([] { check_length("f", "p", 3, 7); }), Equals("f: p has 3 values; expected 1 or 7"));
  CHECK_THAT(message_of([] { check_length("", "n", 0, 2); }), Equals("n has 0 values; expected 1 or 2"));
}

TEST_CASE("parse_enum: one table, one message for an unknown name", "[errors]") {
  CHECK(parse_enum("paint", "colour", "green", kColours) == Colour::kGreen);
  CHECK(enum_name(Colour::kRed, kColours) == "red");
  CHECK_THAT(message_of([] { parse_enum("paint", "colour", "blue", kColours); }),
             Equals("paint: unknown colour 'blue'; known: red, green"));
  const std::vector<std::pair<std::string, Colour>> vec(std::begin(kColours), std::end(kColours));
  CHECK_THAT(message_of([&] { parse_enum("", "colour", "Red", vec); }),
             Equals("unknown colour 'Red'; known: red, green"));
  // The parsers of the library use it: the same format whatever the enum.
  CHECK_THAT(message_of([] { precision_from_name("half"); }),
             Equals("unknown precision 'half'; known: float64, float32"));
  CHECK_THAT(message_of([] { metric_from_name("tvv"); }), StartsWith("distance: unknown metric 'tvv'; known: tv, "));
}

TEST_CASE("throw_invalid without a context starts at the name", "[errors]") {
  CHECK_THAT(message_of([] { throw_invalid("", "k", 2.0, "1"); }), Equals("k = 2 is invalid; expected 1"));
  CHECK_THAT(message_of([] { throw_invalid("f", "k", "'x'", "1"); }), Equals("f: k = 'x' is invalid; expected 1"));
}
