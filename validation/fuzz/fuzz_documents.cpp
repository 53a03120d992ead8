// libFuzzer target: any bytes through every document parser (experiment, bounds, scene, report). InputError is the
// parsers' only way to reject input; any other exception escapes (libFuzzer reports it as a crash), as do ASan/UBSan
// findings.
#include <cstddef>
#include <cstdint>
#include <string_view>

#include "glintlab/validation/documents.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  for (const char* kind : {"experiment", "bounds", "scene", "report", "pipeline"}) {
    try {
      const nlohmann::json doc = glintlab::validation::parse_document(kind, text, "fuzz.json");
      // A normalized document is a fixed point: it must parse again to itself.
      if (glintlab::validation::parse_document(kind, doc.dump(), "fuzz.json") != doc) __builtin_trap();
    } catch (const glintlab::validation::InputError&) {}
  }
  return 0;
}
