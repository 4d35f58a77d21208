"""The comparison, bound and tolerance sites of hand-written C, found by reading it.

A small reader of C, enough for the runtime's and the controllers' headers (not a
compiler): comments, strings and preprocessor lines blanked with every offset kept, the
text cut into tokens, each function's body and parameters found by its braces, and the
names each function (and each struct) declares ``double`` or integer.  From that:

* :func:`comparisons`: every ``<``, ``<=``, ``>``, ``>=``, ``==``, ``!=`` outside a
  ``for`` header, with its two operands (their token spans) and their type (floating,
  integer or unknown) and whether one of them is a literal zero;
* :func:`literals`: every floating literal, and the numbers of ``#define NAME value``;
* :func:`tolerance_reads`: every read of the user's tolerances (``opt[CRT_OPT_RTOL]``,
  ``ATOL``, ``EVENT_TOL``);
* :func:`terms`: the top-level terms of a sum or difference inside a span.

:mod:`derive.verify.mutants` turns these sites into mutants.  Nothing here names a line:
the sites are found again in whatever headers exist, so the catalogue follows the C when
it is split or moved.
"""
from __future__ import annotations

import re
from dataclasses import dataclass, field

_TOKEN = re.compile(r"""
    (?P<num>0[xX][0-9a-fA-F]+[uUlL]*|(?:\d+\.\d*|\.\d+|\d+)(?:[eE][+-]?\d+)?[fFlLuU]*)
  | (?P<id>[A-Za-z_]\w*)
  | (?P<op><<=|>>=|->|\+\+|--|<<|>>|<=|>=|==|!=|&&|\|\||[-+*/%&|^~!=<>?:]=?|[-+*/%&|^]=)
  | (?P<punct>[()\[\]{},;.])
""", re.VERBOSE)

COMPARE = ("<", "<=", ">", ">=", "==", "!=")
FLOAT_FUNCTIONS = frozenset((
    "sqrt", "fabs", "pow", "exp", "log", "sin", "cos", "tan", "asin", "acos", "atan",
    "atan2", "sinh", "cosh", "tanh", "floor", "ceil", "fmod", "hypot", "fmax", "fmin",
    "cbrt", "expm1", "log1p", "copysign", "ldexp"))
FLOAT_CONSTANTS = frozenset(("HUGE_VAL", "NAN", "INFINITY", "M_PI"))
INT_TYPES = frozenset(("int", "long", "short", "unsigned", "char", "size_t", "signed",
                       "enum"))
FLOAT_TYPES = frozenset(("double", "float"))
TYPES = FLOAT_TYPES | INT_TYPES
TYPE_QUALIFIERS = frozenset(("const", "static", "register", "volatile", "inline", "extern"))
# where an operand of a comparison ends (lower precedence, or a bracket it is inside)
_STOP = frozenset(("&&", "||", "?", ":", ",", ";", "{", "}", "=", "+=", "-=", "*=", "/=",
                   "%=", "&=", "|=", "^=", "<<=", ">>=", "&", "|", "^", "return", "if",
                   "while", "else", "case", "do", *COMPARE))
_OPEN, _CLOSE = "([", ")]"


@dataclass(frozen=True)
class Token:
    kind: str
    text: str
    start: int
    end: int


@dataclass
class Function:
    name: str
    returns: str                # "double", "int" or "other"
    body: tuple                 # token index range of the body, braces included
    types: dict                 # name -> "double" | "int" | "mixed"


@dataclass
class Source:
    """One file: its text, the blanked text, its tokens, functions and types."""
    name: str
    text: str
    code: str
    tokens: list
    functions: list
    fields: dict                         # struct fields and file-level names -> type
    returns: dict                        # function name -> its return type
    for_headers: list = field(default_factory=list)   # token index ranges
    defines: list = field(default_factory=list)       # (offset, number) of #define lines

    def function_at(self, i: int) -> Function | None:
        for f in self.functions:
            if f.body[0] <= i <= f.body[1]:
                return f
        return None

    def line_of(self, offset: int) -> int:
        return self.text.count("\n", 0, offset) + 1

    def span_text(self, a: int, b: int) -> str:
        """The source text of tokens a..b (inclusive)."""
        return self.text[self.tokens[a].start:self.tokens[b].end]


def blank(text: str) -> tuple[str, list]:
    """The text with comments, string and character literals and preprocessor lines
    replaced by spaces (newlines kept, offsets unchanged), and the ``#define NAME
    number`` lines as (offset of the number, its text)."""
    out = list(text)
    defines = []
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c == "#":
            j = text.find("\n", i)
            j = n if j < 0 else j
            while j > i and text[j - 1] == "\\" and j < n:     # continued lines
                j2 = text.find("\n", j + 1)
                j = n if j2 < 0 else j2
            line = text[i:j]
            m = re.match(r"#\s*define\s+\w+\s+(\(?\s*)([-+]?(?:\d+\.\d*|\.\d+|\d+)"
                         r"(?:[eE][+-]?\d+)?)\b", line)
            if m:
                defines.append((i + m.start(2), m.group(2)))
            for k in range(i, j):
                if out[k] != "\n":
                    out[k] = " "
            i = j
            continue
        if c == "/" and text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            for k in range(i, j):
                if out[k] != "\n":
                    out[k] = " "
            i = j
            continue
        if c == "/" and text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
            for k in range(i, j):
                out[k] = " "
            i = j
            continue
        if c in "\"'":
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == "\\" else 1
            for k in range(i + 1, min(j, n)):
                if out[k] != "\n":
                    out[k] = " "
            i = j + 1
            line_start = False
            continue
        if c == "\n":
            line_start = True
        elif not c.isspace():
            line_start = False
        i += 1
    return "".join(out), defines


def tokenize(code: str) -> list:
    out = []
    for m in _TOKEN.finditer(code):
        kind = m.lastgroup
        out.append(Token(kind, m.group(), m.start(), m.end()))
    return out


def _match(tokens, i: int) -> int:
    """The index of the bracket closing the one at i."""
    opening = tokens[i].text
    closing = {"(": ")", "[": "]", "{": "}"}[opening]
    depth = 0
    for j in range(i, len(tokens)):
        t = tokens[j].text
        if t == opening:
            depth += 1
        elif t == closing:
            depth -= 1
            if depth == 0:
                return j
    return len(tokens) - 1


def _declared(tokens, a: int, b: int, into: dict) -> None:
    """Declarations among tokens a..b (exclusive): ``[qualifiers] type declarator, ...;``
    and parameter lists; names declared double or integer added to ``into``."""
    i = a
    while i < b:
        t = tokens[i]
        if t.kind == "id" and t.text in TYPES and \
                (i == a or tokens[i - 1].text in (";", "{", "}", "(", ",")
                 or tokens[i - 1].text in TYPE_QUALIFIERS):
            kind = "double" if t.text in FLOAT_TYPES else "int"
            j = i + 1
            while j < b and tokens[j].kind == "id" and tokens[j].text in INT_TYPES:
                j += 1
            if t.text == "enum" and j < b and tokens[j].kind == "id":
                j += 1
            # declarators to ; or to the end of a parameter
            depth = 0
            expect = True
            while j < b:
                x = tokens[j].text
                if x in "([{":
                    depth += 1
                elif x in ")]}":
                    if depth == 0:
                        break
                    depth -= 1
                elif depth == 0 and x == ";":
                    break
                elif depth == 0 and x == ",":
                    expect = True
                    j += 1
                    # a parameter list: the next declarator has its own type
                    if j < b and tokens[j].text in TYPES | TYPE_QUALIFIERS:
                        break
                    continue
                elif depth == 0 and x == "=":
                    expect = False
                if expect and depth == 0 and tokens[j].kind == "id" and \
                        tokens[j].text not in TYPE_QUALIFIERS:
                    mine = f"ptr:{kind}" if tokens[j - 1].text == "*" else kind
                    prev = into.get(tokens[j].text)
                    into[tokens[j].text] = mine if prev in (None, mine) else "mixed"
                    expect = False
                j += 1
            i = j
            continue
        i += 1


def parse(name: str, text: str) -> Source:
    code, defines = blank(text)
    tokens = tokenize(code)
    src = Source(name, text, code, tokens, [], {}, {}, defines=defines)
    # top level: functions (a body after a parameter list) and the rest (structs, enums)
    i = 0
    start = 0
    while i < len(tokens):
        t = tokens[i]
        if t.text == "{":
            j = _match(tokens, i)
            if i > 0 and tokens[i - 1].text == ")":
                # the parameter list's '(' and the name before it
                depth, k = 0, i - 1
                while k >= 0:
                    if tokens[k].text == ")":
                        depth += 1
                    elif tokens[k].text == "(":
                        depth -= 1
                        if depth == 0:
                            break
                    k -= 1
                fname = tokens[k - 1].text if k > 0 else "?"
                head = [x.text for x in tokens[start:k - 1]]
                returns = "double" if "double" in head and "*" not in head else (
                    "int" if set(head) & INT_TYPES else "other")
                types: dict = {}
                _declared(tokens, k + 1, i - 1, types)
                _declared(tokens, i + 1, j, types)
                src.functions.append(Function(fname, returns, (i, j), types))
                src.returns[fname] = returns
            else:
                _declared(tokens, i + 1, j, src.fields)
            i = j + 1
            start = i
            continue
        if t.text == ";":
            _declared(tokens, start, i + 1, src.fields)
            # a prototype: static double name(...);
            head = [x.text for x in tokens[start:i]]
            if "(" in head:
                k = head.index("(")
                if k > 0:
                    src.returns.setdefault(head[k - 1], "double" if "double" in head[:k]
                                           and "*" not in head[:k] else "other")
            start = i + 1
        i += 1
    # for headers
    for i, t in enumerate(tokens):
        if t.text == "for" and i + 1 < len(tokens) and tokens[i + 1].text == "(":
            src.for_headers.append((i + 1, _match(tokens, i + 1)))
    return src


def names(sources: list) -> dict:
    """What every file declares, for the types of the others' operands: function name ->
    return type, ("field", name) -> a struct field's type, ("name", name) -> a file-level
    name's."""
    out: dict = {}
    for src in sources:
        out.update(src.returns)
        for k, v in src.fields.items():
            for key in (("field", k), ("name", k)):
                prev = out.get(key)
                out[key] = v if prev in (None, v) else "mixed"
    return out


# ---- typing of an operand ------------------------------------------------------------
def operand_type(src: Source, a: int, b: int, functions: dict) -> str:
    """"double", "int" or "unknown" for tokens a..b (inclusive); ``functions``: every
    file's function return types (a call's type)."""
    fn = src.function_at(a)
    local = fn.types if fn else {}
    toks = src.tokens
    saw_int = saw_unknown = False
    i = a
    while i <= b:
        t = toks[i]
        if t.text in "([" and i > a and toks[i - 1].kind == "id" and t.text == "[":
            i = _match(toks, i) + 1          # an index: the array's type counts
            continue
        if t.kind == "num":
            if re.search(r"[.eE]", t.text) and not t.text.lower().startswith("0x"):
                return "double"
            saw_int = True
        elif t.kind == "id":
            nxt = toks[i + 1].text if i + 1 <= b else ""
            member = i > a and toks[i - 1].text in (".", "->")
            if t.text in FLOAT_TYPES and i > a and toks[i - 1].text == "(":
                return "double"                  # a cast
            if t.text in INT_TYPES and i > a and toks[i - 1].text == "(":
                saw_int = True                   # (int) x: the cast's type
                j = i
                while j <= b and toks[j].text != ")":
                    j += 1
                i = j + 1
                if i <= b and toks[i].kind == "id":
                    i = _skip_postfix(toks, i, b)
                continue
            if nxt == "(":
                r = functions.get(t.text)
                if t.text in FLOAT_FUNCTIONS or r == "double":
                    return "double"
                if r == "int":
                    saw_int = True
                else:
                    saw_unknown = True
                i = _match(toks, i + 1) + 1
                continue
            if t.text in FLOAT_CONSTANTS:
                return "double"
            if nxt in (".", "->"):
                i += 1                           # a struct's base: its member decides
                continue
            if member:
                kind = src.fields.get(t.text) or functions.get(("field", t.text))
            else:
                kind = local.get(t.text) or src.fields.get(t.text) or \
                    functions.get(("name", t.text))
            if kind and kind.startswith("ptr:"):
                deref = nxt == "[" or (i > a and toks[i - 1].text == "*" and (
                    i - 1 == a or toks[i - 2].kind == "op" or toks[i - 2].text in "(["))
                kind = kind[4:] if deref else "pointer"
            if kind == "double":
                return "double"
            if kind == "int" or (not member and t.text.isupper()):
                saw_int = True
            elif t.text not in TYPE_QUALIFIERS:
                saw_unknown = True
        i += 1
    if saw_unknown:
        return "unknown"
    return "int" if saw_int else "unknown"


def _skip_postfix(toks, i: int, b: int) -> int:
    i += 1
    while i <= b and toks[i].text in ("[", ".", "->"):
        i = _match(toks, i) + 1 if toks[i].text == "[" else i + 2
    return i


def operand_span(src: Source, i: int, direction: int) -> tuple[int, int]:
    """The token span of the operand of the operator at i, to its left (-1) or right
    (+1): up to an unmatched bracket or an operator of lower precedence."""
    toks = src.tokens
    j = i + direction
    depth = 0
    last = i
    while 0 <= j < len(toks):
        x = toks[j].text
        if (x in _OPEN and direction < 0) or (x in _CLOSE and direction > 0):
            if depth == 0:
                break
            depth -= 1
        elif x in _OPEN or x in _CLOSE:
            depth += 1
        elif depth == 0 and x in _STOP:
            break
        last = j
        j += direction
    return (last, i - 1) if direction < 0 else (i + 1, last)


def _is_zero(src: Source, a: int, b: int) -> bool:
    toks = src.tokens[a:b + 1]
    texts = [t.text for t in toks]
    if texts and texts[0] in ("-", "+"):
        texts = texts[1:]
    if len(texts) == 3 and texts[0] == "(" and texts[2] == ")":
        texts = texts[1:2]
    if len(texts) != 1:
        return False
    try:
        return float(texts[0].rstrip("fFlLuU")) == 0.0
    except ValueError:
        return False


@dataclass(frozen=True)
class Comparison:
    src: Source
    op: int                 # token index of the operator
    left: tuple
    right: tuple
    kind: str               # "double", "int" or "unknown" (either operand double: double)
    zero: str               # "" or "left" / "right": the side that is a literal zero

    @property
    def function(self) -> str:
        f = self.src.function_at(self.op)
        return f.name if f else "(file)"

    @property
    def text(self) -> str:
        return self.src.span_text(self.left[0], self.right[1])


def comparisons(src: Source, functions: dict) -> list:
    out = []
    for i, t in enumerate(src.tokens):
        if t.kind != "op" or t.text not in COMPARE:
            continue
        if any(a <= i <= b for a, b in src.for_headers):
            continue
        if src.function_at(i) is None:
            continue
        left = operand_span(src, i, -1)
        right = operand_span(src, i, +1)
        if left[0] > left[1] or right[0] > right[1]:
            continue
        tl = operand_type(src, *left, functions)
        tr = operand_type(src, *right, functions)
        kind = "double" if "double" in (tl, tr) else (
            "int" if tl == tr == "int" else "unknown")
        zero = "left" if _is_zero(src, *left) else ("right" if _is_zero(src, *right) else "")
        out.append(Comparison(src, i, left, right, kind, zero))
    return out


@dataclass(frozen=True)
class Literal:
    src: Source
    start: int              # offset in the text
    text: str
    value: float
    function: str


def literals(src: Source) -> list:
    """Every floating literal inside a function, and every ``#define`` number."""
    out = []
    for i, t in enumerate(src.tokens):
        if t.kind == "num" and re.search(r"[.eE]", t.text) and not t.text.lower() \
                .startswith("0x"):
            f = src.function_at(i)
            if f is None:
                continue
            out.append(Literal(src, t.start, t.text, float(t.text.rstrip("fFlL")), f.name))
    for offset, text in src.defines:
        name = re.match(r"#\s*define\s+(\w+)", src.text[src.text.rfind("\n", 0, offset) + 1:])
        out.append(Literal(src, offset, text, float(text),
                           f"#define {name.group(1) if name else '?'}"))
    return out


def tolerance_reads(src: Source, names=("CRT_OPT_RTOL", "CRT_OPT_ATOL",
                                        "CRT_OPT_EVENT_TOL")) -> list:
    """(start offset, end offset, text, function) of each ``...opt[NAME]`` read."""
    out = []
    toks = src.tokens
    for i, t in enumerate(toks):
        if t.text == "opt" and i + 3 < len(toks) and toks[i + 1].text == "[" and \
                toks[i + 2].text in names and toks[i + 3].text == "]":
            a = i
            while a >= 2 and toks[a - 1].text in (".", "->") and toks[a - 2].kind == "id":
                a -= 2
            f = src.function_at(i)
            if f is None:
                continue
            out.append((toks[a].start, toks[i + 3].end, src.text[toks[a].start:toks[i + 3].end],
                        f.name))
    return out


def terms(src: Source, a: int, b: int) -> list:
    """The top-level terms of the sum in tokens a..b: [(first token, last token)] when
    there are two or more (a binary + or - at depth 0), else []."""
    toks = src.tokens
    cuts = []
    depth = 0
    for j in range(a, b + 1):
        x = toks[j].text
        if x in _OPEN:
            depth += 1
        elif x in _CLOSE:
            depth -= 1
        elif depth == 0 and x in ("+", "-") and j > a:
            prev = toks[j - 1]
            if prev.kind in ("id", "num") or prev.text in (")", "]"):
                cuts.append(j)
            # a ternary at the top level: not a sum of terms
        elif depth == 0 and x in ("?", ":"):
            return []
    if not cuts:
        return []
    out, first = [], a
    for c in cuts:
        out.append((first, c - 1))
        first = c + 1
    out.append((first, b))
    return out


def returns_of(src: Source) -> list:
    """(function, first token, last token) of each ``return expr;`` of a function
    returning double."""
    out = []
    toks = src.tokens
    for f in src.functions:
        if f.returns != "double":
            continue
        for i in range(f.body[0], f.body[1]):
            if toks[i].text == "return":
                j = i + 1
                depth = 0
                while j < f.body[1]:
                    x = toks[j].text
                    if x in _OPEN:
                        depth += 1
                    elif x in _CLOSE:
                        depth -= 1
                    elif x == ";" and depth == 0:
                        break
                    j += 1
                if j - 1 >= i + 1:
                    out.append((f.name, i + 1, j - 1))
    return out
