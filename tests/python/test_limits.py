"""Size limits that keep the rooms readable (docs/architecture.md#limits): no C++ function over 150 lines
(a pybind11 binding function, in bindings/, over 80), no Python function over 100, no source file over
1,000 lines.

Today's exceptions are listed in ``EXCEPTIONS`` with their current length, and the list only shrinks: the
test fails when a listed item grows past its length, and when it no longer exceeds its limit (then delete
its entry). Files that are generated or are tables are in ``NOT_MEASURED``, each with its reason.

    python tests/python/test_limits.py --print    # the EXCEPTIONS dict measured now, to paste
    python tests/python/test_limits.py --update   # rewrite the EXCEPTIONS block of this file in place

C/C++ and shader functions are found by a scanner (``scan_functions``, tested on snippets below): it blanks
comments, string and character literals (raw strings included) and preprocessor lines, then matches braces,
and calls a brace block a function when it is a definition at namespace or class scope (a declarator with a
parameter list, or a variable initialized with a lambda). Lambdas, local classes and blocks inside a
function count toward that function. Python functions are measured with ``ast``, each method and nested
function on its own. A function's length runs from the first line of its declaration to its closing line.
"""
from __future__ import annotations

import ast
import bisect
import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CPP_FUNCTION_LIMIT = 150
BINDING_FUNCTION_LIMIT = 80  # bindings/: a binding function only converts and calls
PYTHON_FUNCTION_LIMIT = 100
FILE_LIMIT = 1000
C_SUFFIXES = {".cpp", ".hpp", ".h", ".inc", ".c", ".cc"}
SHADER_SUFFIXES = {".glsl", ".hlsl", ".comp"}
SOURCE_SUFFIXES = C_SUFFIXES | SHADER_SUFFIXES | {".py"}

# Not measured at all, each with its reason: generated code and tables (none today).
NOT_MEASURED: dict[str, str] = {}

# Items over their limit today, with their length: "path" for a file, "path::function" for a function.
# Regenerate with `python tests/python/test_limits.py --update`; an entry may only be removed or lowered.
# BEGIN EXCEPTIONS
EXCEPTIONS: dict[str, int] = {
}
# END EXCEPTIONS


# ---------------------------------------------------------------------------------------------- the files

def source_files() -> list[str]:
    """Tracked and new (not ignored) source files, as paths relative to the repository root."""
    out = subprocess.run(["git", "ls-files", "-co", "--exclude-standard"], cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout.splitlines()
    return sorted(f for f in set(out)
                  if Path(f).suffix in SOURCE_SUFFIXES and f not in NOT_MEASURED and (ROOT / f).is_file())


# ------------------------------------------------------------------------------------ the C/C++ scanner

# Pass 1 blanks what is not code: comments, character literals, raw strings and preprocessor lines become
# spaces (newlines kept, so line numbers hold), a string literal keeps its quotes around underscores (its
# text is read back from the source, to name a TEST_CASE). A number with a digit separator (1'000) is
# matched first so that its quote does not open a character literal.
_NOT_CODE = re.compile(r"""
    (?P<directive>^[ \t]*\#(?:\\\n|[^\n])*)
  | (?P<line_comment>//(?:\\\n|[^\n])*)
  | (?P<block_comment>/\*.*?\*/)
  | (?P<raw_string>(?:u8|[uUL])?R"(?P<delim>[^()\\\s"]{0,16})\(.*?\)(?P=delim)")
  | (?P<string>"(?:\\.|[^"\\\n])*")
  | (?P<number>(?<![\w.])\d[\w.]*'[\w.']*)
  | (?P<char>'(?:\\.|[^'\\\n])*')
""", re.VERBOSE | re.MULTILINE | re.DOTALL)
# Pass 2 splits the code into tokens.
_TOKEN = re.compile(r""""_*"|[A-Za-z_]\w*|\.?\d(?:[eEpP][+-]|[\w.'])*|::|->|==|!=|<=|>=|&&|\|\||<<|[^\s\w]""")
_PAIRS = {"(": ")", "[": "]", "{": "}"}
_CLOSERS = {")": "(", "]": "[", "}": "{"}
# Words before a parenthesis that do not name a function (a type inside std::function<void()>, an
# attribute, an expression), and words that never name one (a brace after `if (...)` at namespace scope
# means the scanner lost its way).
_NOT_A_NAME = {"void", "bool", "char", "short", "int", "long", "float", "double", "unsigned", "signed", "auto",
               "decltype", "alignas", "__attribute__", "__declspec", "noexcept", "throw", "sizeof", "alignof",
               "static_assert", "requires"}
_CONTROL = {"if", "for", "while", "switch", "catch", "return", "else", "do"}
_SPECIFIERS = {"inline", "static", "constexpr", "consteval", "extern", "virtual", "explicit", "friend",
               "typedef", "export", "thread_local", "mutable"}
_CLASS_KEYS = {"class", "struct", "union"}


class ScanError(ValueError):
    """The scanner cannot follow a file (unbalanced brackets, a brace it cannot classify)."""


def _blank(m: re.Match) -> str:
    text = m.group()
    if m.lastgroup == "string":
        return '"' + "_" * (len(text) - 2) + '"'
    if m.lastgroup == "number":
        return text
    return re.sub(r"[^\n]", " ", text)


class _Tokens:
    """A file's code tokens: text[i], the source offset start[i], for a bracket the index of its match
    close[i], and line(i)."""

    def __init__(self, source: str, path: str):
        self.source = source
        code = _NOT_CODE.sub(_blank, source)
        found = [(m.group(), m.start()) for m in _TOKEN.finditer(code)]
        self.text = [t for t, _ in found]
        self.start = [s for _, s in found]
        self.newlines = [m.start() for m in re.finditer("\n", source)]
        self.close: dict[int, int] = {}
        stack: list[int] = []
        for i, text in enumerate(self.text):
            if text in _PAIRS:
                stack.append(i)
            elif text in _CLOSERS:
                if not stack or self.text[stack[-1]] != _CLOSERS[text]:
                    raise ScanError(f"{path}:{self.line(i)}: unmatched '{text}'")
                self.close[stack.pop()] = i
        if stack:
            raise ScanError(f"{path}:{self.line(stack[-1])}: unclosed '{self.text[stack[-1]]}'")

    def line(self, i: int) -> int:
        return bisect.bisect_right(self.newlines, self.start[i] - 1) + 1

    def is_string(self, i: int) -> bool:
        return self.text[i].startswith('"')

    def literal(self, i: int) -> str:
        """A string token's text as written."""
        return self.source[self.start[i]:self.start[i] + len(self.text[i])]

    def group(self, i: int) -> str:
        """A token as written in a name: an empty bracket pair whole (the () of operator())."""
        text = self.text[i]
        return text + _PAIRS[text] if text in _PAIRS and self.close[i] == i + 1 else text


# A declaration's head is the list of its tokens at bracket depth 0, a bracket group standing as its
# opening token (its contents are the tokens between it and its close).

def _is_name(text: str) -> bool:
    return re.fullmatch(r"[A-Za-z_]\w*", text) is not None


def _strip_prefix(t: _Tokens, head: list[int]) -> list[int]:
    """The head without string literals (extern "C"), leading template<...> clauses, attributes
    ([[...]], HLSL's [numthreads(...)]) and specifiers (static, inline, ...)."""
    head = [i for i in head if not t.is_string(i)]
    k = 0
    while k < len(head):
        text = t.text[head[k]]
        if text == "template" and k + 1 < len(head) and t.text[head[k + 1]] == "<":
            depth, k = 0, k + 1
            while k < len(head):
                word = t.text[head[k]]
                depth += (word == "<") - (word == ">") - 2 * (word == ">>")
                k += 1
                if depth <= 0:
                    break
        elif text == "[" or text in _SPECIFIERS:
            k += 1
        else:
            break
    return head[k:]


def _qualified_name(t: _Tokens, head: list[int], k: int, name: str) -> str:
    """`name` (at head[k]) with its qualifiers: ns::Class<T>::name, Class::~Class."""
    parts = [name]
    j = k - 1
    if j >= 0 and t.text[head[j]] == "~":
        parts.insert(0, "~")
        j -= 1
    while j >= 1 and t.text[head[j]] == "::":
        j -= 1
        if t.text[head[j]] == ">":  # skip Class<T>'s arguments
            depth = 0
            while j >= 0:
                word = t.text[head[j]]
                depth += (word == ">") - (word == "<")
                j -= 1
                if depth == 0:
                    break
        if j < 0 or not _is_name(t.text[head[j]]):
            break
        parts[:0] = [t.text[head[j]], "::"]
        j -= 1
    return "".join(parts)


def _declarator(t: _Tokens, body: list[int]) -> tuple[str, int] | None:
    """(name, index in `body` of its parameter list) of a function declarator, or None."""
    for k, idx in enumerate(body):
        text = t.text[idx]
        if text == "operator":  # operator==, operator(), operator[], operator bool
            j = k + 1
            op = [t.group(body[j])] if j < len(body) and t.text[body[j]] in ("(", "[") else []
            j += len(op)
            while j < len(body) and t.text[body[j]] != "(":
                op.append(t.text[body[j]])
                j += 1
            if j == len(body):
                return None
            spelled = "operator" + ("".join(op) if op and not _is_name(op[0]) else " " + " ".join(op))
            return _qualified_name(t, body, k, spelled), j
        if text != "(" or k == 0:
            continue
        before = t.text[body[k - 1]]
        if _is_name(before) and before not in _NOT_A_NAME:
            if before in _CONTROL:
                raise ScanError(f"line {t.line(idx)}: '{before} (...) {{' outside a function")
            if re.fullmatch(r"[A-Z][A-Z0-9_]*", before) and t.close[idx] > idx + 1 and t.is_string(idx + 1):
                return f"{before}({t.literal(idx + 1)})", k  # TEST_CASE("name", "[tag]")
            return _qualified_name(t, body, k - 1, before), k
    return None


def _classify(t: _Tokens, head: list[int]) -> tuple[str, str]:
    """What the brace after `head` opens: ("namespace" | "class" | "function" | "other", name)."""
    texts = [t.text[i] for i in head if not t.is_string(i)]
    if "namespace" in texts or texts == ["extern"]:
        return "namespace", ""
    body = _strip_prefix(t, head)
    if not body:
        return "other", ""
    first = t.text[body[0]]
    if first in _CLASS_KEYS:
        names = [t.text[i] for i in body[1:] if _is_name(t.text[i]) and t.text[i] != "final"]
        return "class", names[0] if names else ""
    if first == "enum":
        return "other", ""
    eq = [k for k, i in enumerate(body) if t.text[i] == "=" and (k == 0 or t.text[body[k - 1]] != "operator")]
    if eq:  # an initializer: a lambda is a function named by its variable, anything else (a table) is not
        k = eq[0]
        if 0 < k < len(body) - 1 and t.text[body[k + 1]] == "[":
            return "function", t.text[body[k - 1]]
        return "other", ""
    found = _declarator(t, body)
    return ("function", found[0]) if found else ("other", "")


def _member_initializer(t: _Tokens, head: list[int]) -> bool:
    """True when the brace after `head` initializes a member in a constructor's initializer list
    (Foo() : a_{1}, b_(2) {...}): the declarator's parameters are followed by a lone ':' and the brace
    follows a name (the body's brace follows ')' or '}')."""
    body = _strip_prefix(t, head)
    found = _declarator(t, body) if body and t.text[body[0]] not in _CLASS_KEYS else None
    if not found:
        return False
    rest = [t.text[i] for i in body[found[1] + 1:]]
    return ":" in rest and (_is_name(rest[-1]) or rest[-1] == ">")


def scan_functions(source: str, path: str = "<snippet>", shader: bool = False) -> list[tuple[str, int, int]]:
    """(qualified name, first line, last line) of each function defined at namespace or class scope.
    `shader`: HLSL/GLSL, where a ':' after the parameters is a semantic, not an initializer list."""
    t = _Tokens(source, path)
    found: list[tuple[str, int, int]] = []

    def scope(start: int, end: int, classes: list[str]) -> None:
        head: list[int] = []
        i = start
        while i < end:
            text = t.text[i]
            if text in (";", "}"):
                head = []
            elif text == ":" and head and t.text[head[-1]] in ("public", "private", "protected"):
                head = []  # an access specifier
            elif text == "{" and (shader or not _member_initializer(t, head)):
                kind, name = _classify(t, head)
                if kind == "namespace":
                    scope(i + 1, t.close[i], classes)
                elif kind == "class":
                    scope(i + 1, t.close[i], classes + [name])
                elif kind == "function":
                    qualified = name if "::" in name else "::".join(classes + [name])
                    found.append((qualified, t.line(head[0] if head else i), t.line(t.close[i])))
                # After a class or an initializer the declaration goes on to its ';' (struct S {...} s;).
                head = head + [i] if kind in ("class", "other") else []
            else:
                head.append(i)
            i = t.close[i] + 1 if text in _PAIRS else i + 1

    try:
        scope(0, len(t.text), [])
    except ScanError as error:
        raise ScanError(f"{path}: {error}") from None
    return found


# ---------------------------------------------------------------------------------------- the measures

def python_functions(source: str, path: str = "<snippet>") -> list[tuple[str, int, int]]:
    """(qualified name, first line, last line) of every Python function, methods and nested ones too."""
    found: list[tuple[str, int, int]] = []

    def visit(statements: list[ast.stmt], prefix: str) -> None:
        for node in statements:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                name = prefix + node.name
                found.append((name, node.lineno, node.end_lineno or node.lineno))
                visit(node.body, name + ".")
            elif isinstance(node, ast.ClassDef):
                visit(node.body, prefix + node.name + ".")
            else:  # a def inside if/for/while/with/try/match
                for field in ("body", "orelse", "finalbody"):
                    visit(getattr(node, field, []), prefix)
                for inner in getattr(node, "handlers", []) + getattr(node, "cases", []):
                    visit(inner.body, prefix)

    visit(ast.parse(source, filename=path).body, "")
    return found


def measure() -> dict[str, tuple[int, int]]:
    """Every item over its limit: key -> (length, limit)."""
    over: dict[str, tuple[int, int]] = {}
    for path in source_files():
        text = (ROOT / path).read_text(encoding="utf-8", errors="replace")
        lines = text.count("\n") + (0 if text.endswith("\n") or not text else 1)
        if lines > FILE_LIMIT:
            over[path] = (lines, FILE_LIMIT)
        suffix = Path(path).suffix
        if suffix == ".py":
            functions, limit = python_functions(text, path), PYTHON_FUNCTION_LIMIT
        else:
            functions = scan_functions(text, path, shader=suffix in SHADER_SUFFIXES or "/shaders/" in path)
            limit = BINDING_FUNCTION_LIMIT if path.startswith("bindings/") else CPP_FUNCTION_LIMIT
        seen: dict[str, int] = {}
        for name, first, last in functions:
            seen[name] = seen.get(name, 0) + 1
            key = f"{path}::{name}" + (f" #{seen[name]}" if seen[name] > 1 else "")
            if last - first + 1 > limit:
                over[key] = (last - first + 1, limit)
    return over


# ---------------------------------------------------------------------------------------- the limits

def verdict(over: dict[str, tuple[int, int]], exceptions: dict[str, int]) -> list[str]:
    """What is wrong: items over their limit and not listed, listed ones that grew, listed ones now fixed."""
    new = [f"{key}: {length} lines (limit {limit})" for key, (length, limit) in sorted(over.items())
           if key not in exceptions]
    grown = [f"{key}: {over[key][0]} lines, listed at {exceptions[key]}" for key in sorted(exceptions)
             if key in over and over[key][0] > exceptions[key]]
    fixed = [key for key in sorted(exceptions) if key not in over]
    messages = []
    if new:
        messages.append("over the limit: split them (docs/architecture.md#limits):\n  " + "\n  ".join(new))
    if grown:
        messages.append("listed exceptions that grew: shrink them back:\n  " + "\n  ".join(grown))
    if fixed:
        messages.append("now within the limit (or gone): delete their EXCEPTIONS entries in "
                        "tests/python/test_limits.py:\n  " + "\n  ".join(fixed))
    return messages


def test_limits_hold():
    messages = verdict(measure(), EXCEPTIONS)
    assert not messages, "\n".join(messages)


def test_the_verdict_fails_on_new_grown_and_fixed_items():
    listed = {"a.cpp::f": 200, "b.py": 1200}
    assert verdict({"a.cpp::f": (180, 150), "b.py": (1200, 1000)}, listed) == []  # shrunk or equal: fine
    assert "over the limit" in verdict({**{"a.cpp::f": (200, 150), "b.py": (1200, 1000)}, "c.py::g": (101, 100)},
                                       listed)[0]
    assert "grew" in verdict({"a.cpp::f": (201, 150), "b.py": (1200, 1000)}, listed)[0]
    assert "delete their EXCEPTIONS entries" in verdict({"a.cpp::f": (200, 150)}, listed)[0]


def test_lists_name_real_files():
    for key in list(EXCEPTIONS) + list(NOT_MEASURED):
        assert (ROOT / key.split("::")[0]).is_file(), key


# ------------------------------------------------------------------------------ the scanner, on snippets

def names(source: str, **kw) -> dict[str, int]:
    return {name: last - first + 1 for name, first, last in scan_functions(source, **kw)}


def test_scanner_finds_functions_at_namespace_and_class_scope():
    source = """
#include <vector>
namespace a {
namespace {
int helper(int x) { return x; }
}  // namespace
namespace b::c {
template <class T, int N = 3>
std::vector<T> make(
    int n) {
  auto f = [n](int k) {  // a lambda inside counts toward make
    return k + n;
  };
  return {};
}
}  // namespace b::c
class Widget : public Base<Widget> {
 public:
  Widget(int x) : x_{x}, y_(x) { if (x) { x_ = 1; } }
  ~Widget() override {}
  int get() const noexcept { return x_; }
  bool operator==(const Widget& o) const { return x_ == o.x_; }
  double operator()(double t) { return t; }
  struct Inner { void run() {} };
 private:
  int x_{0};
  int y_ = 0;
};
int Widget::Inner::twice(int v) { return 2 * v; }
auto Widget::later() -> int {
  return 1;
}
}  // namespace a
"""
    assert names(source) == {
        "helper": 1, "make": 8, "Widget::Widget": 1, "Widget::~Widget": 1, "Widget::get": 1,
        "Widget::operator==": 1, "Widget::operator()": 1, "Widget::Inner::run": 1, "Widget::Inner::twice": 1,
        "Widget::later": 3}


def test_scanner_ignores_braces_in_comments_literals_and_directives():
    source = r'''
// void commented() {
/* int block() {
} */
#define MACRO(x) { x }
#if 0
#endif
const char* text = "}{";
const char brace = '{';
const long big = 1'000'000;
const char* raw = R"json({"a": {"b": 1}})json";
void real(int n) {
  const char* s = "{";
  char c = '}';
  return;
}
'''
    assert names(source) == {"real": 5}


def test_scanner_tables_enums_and_initializers_are_not_functions():
    source = """
enum class Kind : int { kA, kB };
constexpr double kTable[] = {
  1.0, 2.0,
};
std::vector<int> values{1, 2, 3};
const auto kSquare = [](double x) {
  return x * x;
};
std::function<void(int)> callback{nullptr};
struct Point { double x{0}, y{0}; } origin;
TEST_CASE("blend: a test", "[blend]") {
  SECTION("one") { CHECK(1); }
}
PYBIND11_MODULE(_core, m) {
  m.def("f", [](int x) { return x; });
}
"""
    assert names(source) == {"kSquare": 3, 'TEST_CASE("blend: a test")': 3, "PYBIND11_MODULE": 3}


def test_scanner_local_classes_count_toward_their_function():
    source = """
extern "C" {
int plugin_entry(void) { return 0; }
}
template <>
struct hash<Key> {
  std::size_t operator()(const Key& k) const noexcept { return k.v; }
  explicit operator bool() const { return true; }
};
void with_locals() {
  struct Restore {
    ~Restore() { reset(); }
  } restore;
  class Local { int f() { return 1; } };
}
"""
    assert names(source) == {"plugin_entry": 1, "hash::operator()": 1, "hash::operator bool": 1, "with_locals": 6}


def test_scanner_reads_shaders():
    source = """
#include "glintlab_prelude.h"
struct Input { float x : TEXCOORD0; };
[numthreads(64, 1, 1)]
void main(uint3 id : SV_DispatchThreadID) {
  if (id.x > 3) { return; }
}
float4 ps(float2 uv : TEXCOORD0) : SV_Target {
  return float4(uv, 0, 1);
}
"""
    assert names(source, shader=True) == {"main": 4, "ps": 3}


def test_scanner_refuses_what_it_cannot_follow():
    for source in ("void f() {", "void f() { ) }", "int x;\nif (x) { y(); }"):
        try:
            scan_functions(source)
        except ScanError:
            continue
        raise AssertionError(f"no ScanError for {source!r}")


def test_python_functions_are_measured_with_their_nesting():
    source = "def f():\n    def g():\n        return 1\n    return g\n\n\nclass C:\n    async def m(self):\n" \
             "        pass\n"
    assert python_functions(source) == [("f", 1, 4), ("f.g", 2, 3), ("C.m", 8, 9)]


def test_the_check_fails_on_a_long_function():
    body = "\n".join(f"  x += {i};" for i in range(CPP_FUNCTION_LIMIT))
    assert names(f"int long_one() {{\n{body}\n}}\n")["long_one"] > CPP_FUNCTION_LIMIT


# ------------------------------------------------------------------------------------------ --update

def exceptions_block(over: dict[str, tuple[int, int]]) -> str:
    lines = ["EXCEPTIONS: dict[str, int] = {"]
    lines += [f"    {key!r}: {length}," for key, (length, _) in sorted(over.items())]
    return "\n".join(lines + ["}"])


def test_the_printed_block_is_the_dict():
    over = {"x.cpp::f": (170, 150), "y.py": (1001, 1000)}
    scope: dict = {}
    exec(exceptions_block(over), scope)
    assert scope["EXCEPTIONS"] == {"x.cpp::f": 170, "y.py": 1001}


def main(argv: list[str]) -> int:
    if argv not in (["--print"], ["--update"]):
        print(__doc__)
        return 2
    block = exceptions_block(measure())
    print(block)
    if argv == ["--update"]:
        this = Path(__file__)
        text = this.read_text(encoding="utf-8")
        text = re.sub(r"(# BEGIN EXCEPTIONS\n).*?(\n# END EXCEPTIONS)", lambda m: m.group(1) + block + m.group(2),
                      text, flags=re.DOTALL)
        this.write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
