// The shader runner's compile path (glintlab/validation/shader.hpp): the spec's checks, the Includer
// that serves the user's code and its #includes (UTF-8 checked, include cycles and macro expansion
// bounded before glslang sees them), shaderc's options, and the preprocessed text and SPIR-V of a
// wrapper kernel, a compile failure worded once for every kind of kernel.
#include "glintlab/base/errors.hpp"
#include "glintlab/validation/shader.hpp"

#include <shaderc/shaderc.hpp>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

namespace glintlab::shader {
namespace {

std::string wrapper_name(const std::string& language) {
  return language == "hlsl" ? "glintlab_kernel.hlsl" : "glintlab_kernel.comp";
}

bool is_identifier(const std::string& s) {
  if (s.empty() || !(std::isalpha(static_cast<unsigned char>(s[0])) || s[0] == '_')) return false;
  return std::all_of(s.begin(), s.end(),
                     [](char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; });
}

std::string strip_bom(std::string text) {  // Visual Studio saves UTF-8 with a byte-order mark
  if (text.rfind("\xEF\xBB\xBF", 0) == 0) text.erase(0, 3);
  return text;
}

// The offset of the first byte that is not part of well-formed UTF-8 (RFC 3629: no overlong forms, no
// surrogates, nothing above U+10FFFF), or npos. Shader files are UTF-8, included ones too: a byte of
// another encoding is refused naming its offset rather than passed to the compiler as a guess.
std::size_t invalid_utf8(const std::string& text) {
  const auto* b = reinterpret_cast<const unsigned char*>(text.data());
  const std::size_t n = text.size();
  for (std::size_t i = 0; i < n;) {
    const unsigned c = b[i];
    std::size_t len = 0;
    unsigned lo = 0x80, hi = 0xBF;  // the allowed range of the second byte
    if (c < 0x80) {
      ++i;
      continue;
    }
    if (c >= 0xC2 && c <= 0xDF)
      len = 2;
    else if (c >= 0xE0 && c <= 0xEF) {
      len = 3;
      if (c == 0xE0) lo = 0xA0;
      if (c == 0xED) hi = 0x9F;
    } else if (c >= 0xF0 && c <= 0xF4) {
      len = 4;
      if (c == 0xF0) lo = 0x90;
      if (c == 0xF4) hi = 0x8F;
    } else
      return i;
    if (i + len > n) return i;
    if (b[i + 1] < lo || b[i + 1] > hi) return i;
    for (std::size_t k = 2; k < len; ++k)
      if (b[i + k] < 0x80 || b[i + k] > 0xBF) return i;
    i += len;
  }
  return std::string::npos;
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream f(path, std::ios::binary);
  std::ostringstream s;
  s << f.rdbuf();
  return strip_bom(s.str());
}

// A bound on macro expansion. glslang expands macros with no limit and cannot be interrupted:
// `#define A1 A0 A0`, `#define A2 A1 A1`, ... `A40` asks for 2^40 tokens, and memory runs out before any
// timeout could act (compilation runs in this process). Every file the compiler reads passes through
// the Includer first (the user's file too: the wrapper includes it), so the #define lines of every
// file, and the -D defines, are scanned before the preprocessor sees them, and a macro whose
// replacement, fully expanded, would exceed kMaxMacroTokens tokens is refused by name. The bound
// counts each replacement list's tokens with every macro in it replaced by its own bound; a
// function-like macro's parameters count one token each, and a macro already on the expansion path
// counts one (the preprocessor does not expand it again); inside the parentheses of a call of a
// function-like macro every token counts as many times as the macro repeats a parameter, so nested
// calls F(F(F(x))) multiply, in a replacement list and in each file's code alike.
constexpr double kMaxMacroTokens = 4194304.0;  // 2^22 tokens: tens of MB of text

class MacroBounds {
 public:
  // The #define lines of one source text (comments and line continuations removed first).
  void add_source(const std::string& text) {
    std::istringstream lines(strip_comments(text));
    std::string code;  // the lines that are not directives: where the macros get called
    for (std::string line; std::getline(lines, line);) {
      std::size_t i = line.find_first_not_of(" \t");
      if (i == std::string::npos || line[i] != '#') {
        code += line;
        code += '\n';
        continue;
      }
      i = line.find_first_not_of(" \t", i + 1);
      if (i == std::string::npos || line.compare(i, 6, "define") != 0) continue;
      i = line.find_first_not_of(" \t", i + 6);
      if (i == std::string::npos || !ident_start(line[i])) continue;
      std::size_t e = i;
      while (e < line.size() && ident_char(line[e])) ++e;
      const std::string name = line.substr(i, e - i);
      std::set<std::string> params;
      if (e < line.size() && line[e] == '(') {  // function-like: no space before the parenthesis
        const std::size_t close = line.find(')', e);
        const std::string list = line.substr(e + 1, (close == std::string::npos ? line.size() : close) - e - 1);
        for (const auto& t : tokens(list)) params.insert(t);
        e = close == std::string::npos ? line.size() : close + 1;
      }
      define(name, line.substr(e), std::move(params));
    }
    std::map<std::string, double> memo;
    std::set<std::string> open;
    code_tokens_ = std::max(code_tokens_, sequence(tokens(code), {}, "", open, memo));
  }
  void define(const std::string& name, const std::string& body, std::set<std::string> params = {}) {
    macros_[name] = Macro{tokens(body), std::move(params)};
  }
  // The first macro (in name order) whose bound exceeds kMaxMacroTokens, with its bound; "" if none.
  std::string over(double& bound, const std::string& file) const {
    std::map<std::string, double> memo;
    for (const auto& entry : macros_) {
      std::set<std::string> open;
      bound = size(entry.first, open, memo);
      if (bound > kMaxMacroTokens)
        return "macro " + entry.first +
               (file.empty() ? " (from defines)" : " (defined in " + file + " or a file before it)");
    }
    bound = code_tokens_;
    if (bound > kMaxMacroTokens) return "the code of " + file + " (nested calls of function-like macros)";
    return "";
  }
  // "" while every bound holds; else the refusal, naming the macro and `file` (the file just read,
  // "" for the defines).
  std::string message(const std::string& file) const {
    double bound = 0;
    const std::string name = over(bound, file);
    if (name.empty()) return "";
    char n[32];
    std::snprintf(n, sizeof n, "%.3g", bound);
    return name + " expands to " + n + " tokens, more than " + std::to_string(static_cast<long long>(kMaxMacroTokens)) +
           " (each macro that repeats another multiplies its size: the compiler would run out of memory); "
           "define it with fewer repetitions or as a function";
  }

 private:
  struct Macro {
    std::vector<std::string> body;
    std::set<std::string> params;
  };
  static bool ident_start(char c) { return std::isalpha(static_cast<unsigned char>(c)) || c == '_'; }
  static bool ident_char(char c) { return std::isalnum(static_cast<unsigned char>(c)) || c == '_'; }
  // Identifiers, numbers and string literals as one token each; any other character as one token
  // (an over-count, on the safe side of the bound).
  static std::vector<std::string> tokens(const std::string& s) {
    std::vector<std::string> out;
    for (std::size_t i = 0; i < s.size();) {
      const char c = s[i];
      std::size_t e = i + 1;
      if (std::isspace(static_cast<unsigned char>(c))) {
        i = e;
        continue;
      }
      if (ident_start(c) || std::isdigit(static_cast<unsigned char>(c)))
        while (e < s.size() && (ident_char(s[e]) || s[e] == '.')) ++e;
      else if (c == '"')
        while (e < s.size() && s[e++] != '"') {}
      out.push_back(s.substr(i, e - i));
      i = e;
    }
    return out;
  }
  static std::string strip_comments(const std::string& text) {
    std::string out;
    out.reserve(text.size());
    for (std::size_t i = 0; i < text.size(); ++i) {
      if (text[i] == '\\' && i + 1 < text.size() && text[i + 1] == '\n') {
        ++i;
        continue;
      }
      if (text[i] == '\\' && i + 2 < text.size() && text[i + 1] == '\r' && text[i + 2] == '\n') {
        i += 2;
        continue;
      }
      if (text[i] == '/' && i + 1 < text.size() && text[i + 1] == '/') {
        while (i < text.size() && text[i] != '\n') ++i;
        if (i < text.size()) out += '\n';
        continue;
      }
      if (text[i] == '/' && i + 1 < text.size() && text[i + 1] == '*') {
        const std::size_t end = text.find("*/", i + 2);
        const std::size_t stop = end == std::string::npos ? text.size() : end + 2;
        out += ' ';
        out.append(static_cast<std::size_t>(std::count(text.begin() + static_cast<std::ptrdiff_t>(i),
                                                       text.begin() + static_cast<std::ptrdiff_t>(stop), '\n')),
                   '\n');
        i = stop - 1;
        continue;
      }
      out += text[i];
    }
    return out;
  }
  // The expanded size of a token sequence: a macro counts its bound, and every token inside the
  // arguments of a call of a function-like macro counts as many times as that macro repeats a
  // parameter (nested calls multiply). With `count_only` set, only that identifier (a parameter)
  // counts: the number of copies of it the sequence makes.
  double sequence(const std::vector<std::string>& ts, const std::set<std::string>& params,
                  const std::string& count_only, std::set<std::string>& open,
                  std::map<std::string, double>& memo) const {
    double total = 0, weight = 1;
    std::vector<double> weights;  // the weight outside each open parenthesis
    double call = 0;              // the repetition of the function-like macro whose '(' comes next
    for (std::size_t k = 0; k < ts.size() && total <= 1e300; ++k) {
      const std::string& t = ts[k];
      const bool counts = count_only.empty() || t == count_only;
      // Parentheses count at the weight outside them (a call's own are not copied with its argument).
      if (t == "(") {
        if (count_only.empty()) total += weight;
        weights.push_back(weight);
        if (call > 0) weight *= call;
        call = 0;
        continue;
      }
      call = 0;
      if (t == ")") {
        if (!weights.empty()) weight = weights.back(), weights.pop_back();
        if (count_only.empty()) total += weight;
        continue;
      }
      const auto it = macros_.find(t);
      if (!ident_start(t[0]) || params.count(t) || it == macros_.end() || open.count(t)) {
        if (counts) total += weight;
        continue;
      }
      if (count_only.empty()) total += weight * size(t, open, memo);
      if (!it->second.params.empty() && k + 1 < ts.size() && ts[k + 1] == "(") call = repetition(t, open, memo);
    }
    return total;
  }
  // A macro's bound: its replacement's expanded size, parameters one token each.
  double size(const std::string& name, std::set<std::string>& open, std::map<std::string, double>& memo) const {
    const auto it = macros_.find(name);
    if (it == macros_.end() || open.count(name)) return 1.0;
    if (const auto m = memo.find(name); m != memo.end()) return m->second;
    open.insert(name);
    const double s = sequence(it->second.body, it->second.params, "", open, memo);
    open.erase(name);
    memo[name] = s;
    return s;
  }
  // The most copies a function-like macro makes of one of its arguments (at least 1).
  double repetition(const std::string& name, std::set<std::string>& open, std::map<std::string, double>& memo) const {
    const auto it = macros_.find(name);
    const std::string key = "(" + name;  // its own memo entries, apart from the sizes
    if (const auto m = memo.find(key); m != memo.end()) return m->second;
    open.insert(name);
    double r = 1;
    for (const auto& p : it->second.params)
      r = std::max(r, sequence(it->second.body, it->second.params, p, open, memo));
    open.erase(name);
    memo[key] = r;
    return r;
  }
  std::map<std::string, Macro> macros_;
  double code_tokens_ = 0;  // the largest expanded size of one file's code so far
};

// What the includes of one preprocess or compile have done so far. glslang reports the depth of each
// #include it asks for (1: the user's file, included by the wrapper), so the open chain is exact
// without relying on when it releases a file.
struct IncludeState {
  std::vector<std::string> chain;  // chain[d - 1]: the file open at depth d
  int count = 0;
  std::string failure;  // once an include limit is hit, every later #include fails with it (bounded work)
  std::vector<std::pair<std::string, std::string>>* included = nullptr;
  MacroBounds macros;         // every #define seen so far (and the -D defines)
  std::string macro_failure;  // set when a macro's expansion bound is exceeded (then nothing more is served)
};

std::string short_name(const std::string& path) {
  const std::string name = std::filesystem::path(path).filename().string();
  return name.empty() ? path : name;
}

// Serves the user's code under its own name (so the compiler's messages say file:line) and resolves
// its #include "x" relative to the including file, then the include directories (or, for a sealed
// spec, among the recorded include_files only).
class Includer final : public shaderc::CompileOptions::IncluderInterface {
 public:
  Includer(const KernelSpec& spec, std::shared_ptr<IncludeState> state)
      : user_name_(spec.source_name), user_source_(strip_bom(spec.source)), dirs_(spec.include_dirs),
        sealed_(spec.include_files.begin(), spec.include_files.end()), is_sealed_(!spec.include_files.empty()),
        state_(std::move(state)) {}

  shaderc_include_result* GetInclude(const char* requested, shaderc_include_type, const char* requesting,
                                     std::size_t depth) override {
    auto* r = new Result;
    IncludeState& st = *state_;
    if (user_name_ == requested && std::string(requesting).rfind("glintlab_kernel.", 0) == 0) {
      r->name = user_name_;
      r->content = user_source_;
    } else if (!st.failure.empty()) {
      r->content = st.failure;
    } else {
      std::vector<std::filesystem::path> candidates;
      const std::filesystem::path from(requesting);
      if (from.has_parent_path())
        candidates.push_back(from.parent_path() / requested);
      else
        candidates.push_back(std::filesystem::path(requested));
      for (const auto& d : dirs_) candidates.push_back(std::filesystem::path(d) / requested);
      std::string found, content;
      for (const auto& c : candidates) {
        if (is_sealed_) {
          if (auto it = sealed_.find(c.string()); it != sealed_.end()) {
            found = it->first;
            content = it->second;
            break;
          }
          continue;
        }
        std::error_code ec;
        if (std::filesystem::is_regular_file(c, ec)) {
          found = c.string();
          content = read_file(c);
          break;
        }
      }
      const std::size_t bad = found.empty() ? std::string::npos : invalid_utf8(content);
      if (found.empty()) {
        r->content = std::string("cannot find include file '") + requested + "'" +
                     (is_sealed_ ? " among the files recorded when the law was first compiled" : "");
      } else if (bad != std::string::npos) {
        char hex[8];
        std::snprintf(hex, sizeof hex, "0x%02x", static_cast<unsigned char>(content[bad]));
        r->content =
            found + ": byte " + hex + " at offset " + std::to_string(bad) + " (line " +
            std::to_string(1 + std::count(content.begin(), content.begin() + static_cast<std::ptrdiff_t>(bad), '\n')) +
            ") is not UTF-8; expected a UTF-8 file (save it as UTF-8)";
      } else if (static_cast<int>(depth) > kMaxIncludeDepth || ++st.count > kMaxIncludes) {
        st.failure = limit_message(found, static_cast<int>(depth) > kMaxIncludeDepth);
        r->content = st.failure;
      } else {
        r->name = found;
        r->content = std::move(content);
        if (st.included &&
            std::none_of(st.included->begin(), st.included->end(), [&](const auto& f) { return f.first == found; }))
          st.included->emplace_back(found, r->content);
      }
    }
    if (!r->name.empty()) {
      // Scan the file's macros before the preprocessor expands any of them (the bound above).
      st.macros.add_source(r->content);
      if (st.macro_failure.empty()) st.macro_failure = st.macros.message(short_name(r->name));
      if (!st.macro_failure.empty()) {
        r->name.clear();
        r->content = st.macro_failure;
      }
    }
    if (!r->name.empty()) {
      st.chain.resize(depth > 0 ? depth - 1 : 0);
      st.chain.push_back(r->name);
    }
    r->result.source_name = r->name.c_str();
    r->result.source_name_length = r->name.size();
    r->result.content = r->content.c_str();
    r->result.content_length = r->content.size();
    r->result.user_data = r;
    return &r->result;
  }
  void ReleaseInclude(shaderc_include_result* data) override { delete static_cast<Result*>(data->user_data); }

 private:
  std::string limit_message(const std::string& next, bool depth) const {
    const auto& chain = state_->chain;
    // The cycle: through `next` (its latest opening), else the latest file open twice in the chain
    // (the limit may trip on a leaf included from inside a cycle).
    std::vector<std::string> full = chain;
    full.push_back(next);
    for (std::size_t end = full.size(); end-- > 1;)
      for (std::size_t i = end; i-- > 0;)
        if (full[i] == full[end]) {
          std::string cycle;
          for (std::size_t k = i; k <= end; ++k) cycle += (k > i ? " -> " : "") + short_name(full[k]);
          return "#include cycle " + cycle + " (" + full[end] +
                 " includes itself through this chain; #pragma "
                 "once is not honoured by the shader compiler: guard the file with #ifndef/#define or remove "
                 "the include)";
        }
    std::string path;
    for (const auto& f : full) path += (path.empty() ? "" : " -> ") + short_name(f);
    if (depth) return "#include nested deeper than " + std::to_string(kMaxIncludeDepth) + " files (" + path + ")";
    return "more than " + std::to_string(kMaxIncludes) + " #include directives processed (last: " + path + ")";
  }
  struct Result {
    shaderc_include_result result{};
    std::string name, content;
  };
  std::string user_name_, user_source_;
  std::vector<std::string> dirs_;
  std::map<std::string, std::string> sealed_;
  bool is_sealed_ = false;
  std::shared_ptr<IncludeState> state_;
};

shaderc::CompileOptions options(const KernelSpec& spec, std::shared_ptr<IncludeState> state) {
  shaderc::CompileOptions o;
  o.SetSourceLanguage(spec.language == "hlsl" ? shaderc_source_language_hlsl : shaderc_source_language_glsl);
  o.SetTargetEnvironment(shaderc_target_env_vulkan,
                         spec.vulkan_1_1 ? shaderc_env_version_vulkan_1_1 : shaderc_env_version_vulkan_1_0);
  o.SetOptimizationLevel(shaderc_optimization_level_performance);
  o.SetGenerateDebugInfo();  // no effect on the code; keeps names in the SPIR-V for inspection
  // The user's own textures, buffers and uniform blocks may come without a binding: shaderc gives them
  // one, and the runner moves them all to set 1 anyway (remap_user_resources).
  o.SetAutoBindUniforms(true);
  // A define without a value (Python None, the empty string) is `#define NAME`, as `-D NAME` would be.
  for (const auto& [name, value] : spec.defines) o.AddMacroDefinition(name, value);
  o.AddMacroDefinition("GLINTLAB_N_UNIFORMS", std::to_string(spec.n_uniforms));
  o.SetIncluder(std::make_unique<Includer>(spec, std::move(state)));
  return o;
}

// `signature`: the entry's expected signature(s) as the kind's declaration words them ("": a counting
// law's, the default contract).
[[noreturn]] void compile_failure(const KernelSpec& spec, const std::string& messages, const std::string& signature) {
  // Only when every error is inside glintlab's wrapper did the call to the entry not match; an error
  // in the user's code (a missing `;`) also breaks the wrapper's call, and is the one to show.
  const std::string wrapper = wrapper_name(spec.language) + ":";
  bool wrapper_only = messages.find(wrapper) != std::string::npos;
  std::istringstream lines(messages);
  for (std::string line; std::getline(lines, line);)
    if (line.find("error") != std::string::npos && line.rfind(wrapper, 0) != 0 &&
        line.find("error(s) generated") == std::string::npos && line.find("errors generated") == std::string::npos)
      wrapper_only = false;
  if (wrapper_only)
    glintlab::throw_invalid_message(
        "shader " + spec.source_name + ": no function " + spec.entry + " with the expected signature " +
        (signature.empty() ? wrapper_signature(law_wrapper(spec.entry), spec.language) : signature) + " (" +
        spec.language + "); the compiler says:\n" + messages);
  glintlab::throw_invalid_message("shader " + spec.source_name + " does not compile (" + spec.language +
                                  "); the compiler says:\n" + messages);
}

}  // namespace

void validate_spec(const KernelSpec& spec) {
  if (spec.language != "hlsl" && spec.language != "glsl")
    glintlab::throw_invalid("", "language", "'" + spec.language + "'", "'hlsl' or 'glsl'");
  if (!is_identifier(spec.entry)) glintlab::throw_invalid("", "entry", "'" + spec.entry + "'", "a function name");
  if (spec.n_uniforms < 0 || spec.n_uniforms > 4)
    glintlab::throw_invalid("", "n_uniforms", std::to_string(spec.n_uniforms), "0 to 4");
  for (const auto& [name, value] : spec.defines) {
    if (!is_identifier(name))
      glintlab::throw_invalid_message("defines: name '" + name + "' is invalid; expected an identifier");
    if (value.find_first_of("\r\n") != std::string::npos)
      glintlab::throw_invalid_message("defines: " + name + " = '" + value +
                                      "' is invalid; expected a value on one line");
  }
  if (spec.source_name.empty() || spec.source_name.rfind("glintlab_kernel.", 0) == 0)
    glintlab::throw_invalid("", "source_name", "'" + spec.source_name + "'", "a file name");
}

std::string preprocess(const KernelSpec& spec, const std::string& wrapper,
                       std::vector<std::pair<std::string, std::string>>* included, const std::string& signature) {
  auto state = std::make_shared<IncludeState>();
  state->included = included;
  for (const auto& [name, value] : spec.defines) state->macros.define(name, value);
  if (const std::string m = state->macros.message(""); !m.empty())
    glintlab::throw_invalid_message("shader " + spec.source_name + ": " + m);
  shaderc::Compiler compiler;
  auto pre = compiler.PreprocessGlsl(wrapper, shaderc_glsl_compute_shader, wrapper_name(spec.language).c_str(),
                                     options(spec, state));
  if (!state->macro_failure.empty())
    glintlab::throw_invalid_message("shader " + spec.source_name + ": " + state->macro_failure);
  if (pre.GetCompilationStatus() != shaderc_compilation_status_success)
    compile_failure(spec, pre.GetErrorMessage(), signature);
  return std::string(pre.cbegin(), pre.cend());
}

std::vector<std::uint32_t> compile_spirv(const KernelSpec& spec, const std::string& wrapper,
                                         const std::string& entry_point, const std::string& signature) {
  shaderc::Compiler compiler;
  auto res = compiler.CompileGlslToSpv(wrapper, shaderc_glsl_compute_shader, wrapper_name(spec.language).c_str(),
                                       entry_point.c_str(), options(spec, std::make_shared<IncludeState>()));
  if (res.GetCompilationStatus() != shaderc_compilation_status_success)
    compile_failure(spec, res.GetErrorMessage(), signature);
  return std::vector<std::uint32_t>(res.cbegin(), res.cend());
}

}  // namespace glintlab::shader
