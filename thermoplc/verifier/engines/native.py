"""The fast replay engine: the parsed block translated to C, compiled by the system C compiler.

The interpreter stays the reference semantics; this engine must give the same bits. It does,
because C `float` arithmetic on x86-64 SSE is binary32 with round-to-nearest-even per operation
when contraction is off (-ffp-contract=off, no fast-math): the same rounding the interpreter
applies after each operation. Comparisons use the quiet C99 macros so NaN inputs do not raise
flags. Whatever the interpreter would stop on or report (a VAR_TEMP read before it is written,
an index out of range, INT overflow, a runaway loop, and through the FPU's sticky flags any NaN,
Inf, division by zero or subnormal) makes a chunk return early, and the caller replays with the
interpreter, which then gives its exact message or finding.
"""
from __future__ import annotations

import ctypes
import hashlib
import os
import shlex
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

from thermoplc.verifier.engines import native_cache
from thermoplc.verifier.reading import syntax as s
from thermoplc.base.binary32 import INT_RANGES
from thermoplc.verifier.engines.semantics import CONVERSIONS, MAX_LOOP_ITERATIONS, int_result_kind, literal_kind

CFLAGS = ["-O2", "-std=gnu99", "-fPIC", "-shared", "-ffp-contract=off", "-fno-fast-math", "-fexcess-precision=standard"]
X86_FLAGS = ["-msse2", "-mfpmath=sse"]
STATUS_FLAGS = 2  # status[0]: FPU flags raised, status[1]: first cycle the chunk could not run
SYMBOLS = ("run", "state_size", "state_init")  # what NativeBlock calls: a cached library without one is rebuilt


def _int(value: str, kind: str) -> str:
    """An integer intermediate checked against its type (INT or DINT), as the interpreter does: operands
    are at most DINT, so the int64 operation itself cannot overflow, and an out-of-range result leaves
    the fast run."""
    lo, hi = INT_RANGES[kind]
    return f"({{ int64_t r_ = {value}; if (r_ < {lo}LL || r_ > {hi}LL) goto fail; r_; }})"


class NativeUnavailable(Exception):
    """The block cannot run natively here; the message says why (no compiler, EXP in the block, ...)."""


def _cname(name: str) -> str:
    return "v_" + name.upper()


def _real_literal(value: float) -> str:
    return f"{float(np.float32(value)).hex()}f" if np.isfinite(value) else ("NAN" if value != value else
                                                                            ("INFINITY" if value > 0 else "-INFINITY"))


class _Translator:
    """checked=False drops the run-time checks (unset temps, index and INT ranges): the plain C loop
    over the same arithmetic that benchmarks/replay.py uses as the physical limit."""

    def __init__(self, program: s.Program, checked: bool = True):
        self.decls = {d.name.upper(): d for d in program.decls}
        self.program = program
        self.checked = checked

    # -- types -------------------------------------------------------------------------------------
    def ctype(self, d: s.VarDecl) -> str:
        return {"REAL": "float", "BOOL": "unsigned char"}.get(d.type.base, "int64_t")

    def decl(self, name: str) -> s.VarDecl:
        d = self.decls.get(name.upper())
        if d is None:
            raise NativeUnavailable(f"{name} is not declared")
        return d

    # -- expressions -------------------------------------------------------------------------------
    def expr(self, e) -> tuple[str, str]:
        if isinstance(e, s.RealLit):
            return _real_literal(e.value), "REAL"
        if isinstance(e, s.IntLit):
            return f"((int64_t){e.value}LL)", literal_kind(e.value)
        if isinstance(e, s.BoolLit):
            return ("1" if e.value else "0"), "BOOL"
        if isinstance(e, s.Name):
            return self.read(e.name, None)
        if isinstance(e, s.Index):
            return self.read(e.name, e.index)
        if isinstance(e, s.Unary):
            inner, kind = self.expr(e.operand)
            if e.op == "NOT":
                return f"(!{inner})", "BOOL"
            return (_int(f"(-{inner})", kind) if kind in INT_RANGES else f"(-{inner})"), kind
        if isinstance(e, s.Call):
            return self.call(e)
        return self.binop(e)

    def read(self, name: str, index) -> tuple[str, str]:
        d = self.decl(name)
        kind = d.type.base
        c = _cname(d.name)
        temp = d.section == "temp" and self.checked
        if index is None:
            return (f"({{ if (!w_{c}) goto fail; {c}; }})" if temp else c), kind
        i, _ = self.expr(index)
        lo, hi = d.type.bounds
        check = f"if (i_ < {lo} || i_ > {hi}) goto fail;" if self.checked else ""
        written = f"if (!w_{c}[i_ - {lo}]) goto fail;" if temp else ""
        return f"({{ int64_t i_ = {i}; {check} {written} {c}[i_ - {lo}]; }})", kind

    def call(self, e: s.Call) -> tuple[str, str]:
        args = [self.expr(a)[0] for a in e.args]
        if e.func in CONVERSIONS:
            return f"((float)({args[0]}))", "REAL"
        if e.func == "ABS":
            return f"fabsf({args[0]})", "REAL"
        if e.func == "SQRT":
            return f"sqrtf({args[0]})", "REAL"
        if e.func == "MIN":
            return f"f_min({args[0]}, {args[1]})", "REAL"
        if e.func == "MAX":
            return f"f_max({args[0]}, {args[1]})", "REAL"
        raise NativeUnavailable(f"{e.func} is not a portable operation; the fast engine runs portable operations only")

    def binop(self, e: s.BinOp) -> tuple[str, str]:
        (a, ka), (b, kb) = self.expr(e.left), self.expr(e.right)
        op = e.op
        if op in ("AND", "OR", "XOR"):
            return {"AND": f"(({a}) & ({b}))", "OR": f"(({a}) | ({b}))", "XOR": f"(({a}) != ({b}))"}[op], "BOOL"
        if op in ("=", "<>", "<", "<=", ">", ">="):
            if ka == "REAL":
                quiet = {"<": "isless", "<=": "islessequal", ">": "isgreater", ">=": "isgreaterequal"}
                if op in quiet:
                    return f"({quiet[op]}({a}, {b}) != 0)", "BOOL"
            return f"(({a}) {'==' if op == '=' else '!=' if op == '<>' else op} ({b}))", "BOOL"
        if ka == "REAL":
            if op not in ("+", "-", "*", "/"):
                raise NativeUnavailable(f"'{op}' on REAL is not a portable operation")
            return f"({a} {op} {b})", "REAL"
        kind = int_result_kind(ka, kb)
        if op in ("/", "MOD"):
            return _int(f"({{ int64_t d_ = {b}; if (d_ == 0) goto fail; ({a}) {'/' if op == '/' else '%'} d_; }})",
                        kind), kind
        return _int(f"({a} {op} {b})", kind), kind

    # -- statements --------------------------------------------------------------------------------
    def stmts(self, body, pad: str) -> list[str]:
        out = []
        for st in body:
            if isinstance(st, s.Region):
                out += self.stmts(st.body, pad)
            elif isinstance(st, s.Assign):
                out += self.assign(st, pad)
            elif isinstance(st, s.If):
                for k, (cond, branch) in enumerate(st.branches):
                    c, _ = self.expr(cond)
                    out.append(f"{pad}{'if' if k == 0 else '} else if'} ({c}) {{")
                    out += self.stmts(branch, pad + "    ")
                if st.orelse:
                    out.append(f"{pad}}} else {{")
                    out += self.stmts(st.orelse, pad + "    ")
                out.append(f"{pad}}}")
            else:
                out += self.for_loop(st, pad)
        return out

    def _store(self, d: s.VarDecl, target: str, value: str, pad: str) -> list[str]:
        if d.type.base in INT_RANGES and self.checked:
            lo, hi = INT_RANGES[d.type.base]
            return [f"{pad}{{ int64_t x_ = {value}; if (x_ < {lo}LL || x_ > {hi}LL) goto fail; {target} = x_; }}"]
        return [f"{pad}{target} = {value};"]

    def assign(self, st: s.Assign, pad: str) -> list[str]:
        d = self.decl(st.target.name)
        if d.section in ("constant", "input"):
            raise NativeUnavailable(f"assignment to {d.section} {d.name}")
        value, _ = self.expr(st.value)
        c = _cname(d.name)
        temp = d.section == "temp" and self.checked
        if isinstance(st.target, s.Index):
            i, _ = self.expr(st.target.index)
            lo, hi = d.type.bounds
            lines = [f"{pad}{{ int64_t j_ = {i}; if (j_ < {lo} || j_ > {hi}) goto fail;"]
            lines += self._store(d, f"{c}[j_ - {lo}]", value, pad + "  ")
            if temp:
                lines.append(f"{pad}  w_{c}[j_ - {lo}] = 1;")
            return lines + [f"{pad}}}"]
        return self._store(d, c, value, pad) + ([f"{pad}w_{c} = 1;"] if temp else [])

    def for_loop(self, st: s.For, pad: str) -> list[str]:
        d = self.decl(st.var)
        c = _cname(d.name)
        start, _ = self.expr(st.start)
        stop, _ = self.expr(st.stop)
        step = self.expr(st.step)[0] if st.step is not None else "1"
        lo, hi = INT_RANGES[d.type.base]
        lines = [f"{pad}{{ int64_t i_ = {start}, e_ = {stop}, s_ = {step}; if (s_ == 0) goto fail;",
                 f"{pad}  while (s_ > 0 ? i_ <= e_ : i_ >= e_) {{",
                 f"{pad}    if (++loops_ > {MAX_LOOP_ITERATIONS}) goto fail;  /* one budget per call, as the interpreter */",
                 f"{pad}    if (i_ < {lo}LL || i_ > {hi}LL) goto fail;",
                 f"{pad}    {c} = i_;" + (f" w_{c} = 1;" if d.section == "temp" else "")]
        lines += self.stmts(st.body, pad + "    ")
        lines += [f"{pad}    i_ = {c} + s_;", f"{pad}  }}",
                  f"{pad}  if (i_ < {lo}LL || i_ > {hi}LL) goto fail;",
                  f"{pad}  {c} = i_;" + (f" w_{c} = 1;" if d.section == "temp" else "") + " }"]
        return lines

    # -- the whole unit ----------------------------------------------------------------------------
    def initial(self, d: s.VarDecl) -> str:
        def one(v):
            if d.type.base == "REAL":
                return _real_literal(float(v))
            return str(int(v))
        if d.type.bounds:
            lo, hi = d.type.bounds
            values = list(d.initial) if isinstance(d.initial, tuple) else []
            values += [0] * (hi - lo + 1 - len(values))
            return "{" + ", ".join(one(v) for v in values) + "}"
        return one(d.initial) if d.initial is not None else "0"

    def source(self) -> str:
        decls = self.program.decls
        memory = [d for d in decls if d.section in ("static", "output", "input")]
        temps = [d for d in decls if d.section == "temp"]
        constants = [d for d in decls if d.section == "constant"]
        inputs = [d for d in decls if d.section == "input"]
        outputs = [d for d in decls if d.section == "output"]

        def size(d):
            return "" if not d.type.bounds else f"[{d.type.bounds[1] - d.type.bounds[0] + 1}]"
        lines = ["#include <math.h>", "#include <stdint.h>", "#include <string.h>", "#include <fenv.h>",
                 "#if defined(__SSE__)", "#include <xmmintrin.h>", "#endif",
                 "static inline float f_min(float a, float b) { return isless(b, a) ? b : a; }",
                 "static inline float f_max(float a, float b) { return isgreater(b, a) ? b : a; }",
                 "typedef struct {"]
        lines += [f"    {self.ctype(d)} {_cname(d.name)}{size(d)};" for d in memory] or ["    int unused_;"]
        lines += ["} state_t;", "int64_t state_size(void) { return (int64_t)sizeof(state_t); }",
                  "void state_init(state_t *s) {", "    memset(s, 0, sizeof(state_t));"]
        for d in memory:
            if d.initial is not None:
                lines.append(f"    {{ {self.ctype(d)} x_{size(d)} = {self.initial(d)}; memcpy(&s->{_cname(d.name)}, &x_, sizeof x_); }}")
        lines += ["}",
                  "int64_t run(state_t *s, int64_t rows, void **in, void **out, int64_t *status) {",
                  "    int64_t j = 0, loops_ = 0;", "    feclearexcept(FE_ALL_EXCEPT);",
                  "#if defined(__SSE__)", "    _mm_setcsr(_mm_getcsr() & ~0x3Fu);", "#endif"]
        for d in constants:
            lines.append(f"    const {self.ctype(d)} {_cname(d.name)}{size(d)} = {self.initial(d)};")
        for d in memory:
            ref = f"s->{_cname(d.name)}"
            if d.type.bounds:
                lines.append(f"    {self.ctype(d)} *{_cname(d.name)} = {ref};")
            else:
                lines.append(f"    {self.ctype(d)} {_cname(d.name)} = {ref};")
        for d in temps:
            lines.append(f"    {self.ctype(d)} {_cname(d.name)}{size(d)}; unsigned char w_{_cname(d.name)}{size(d)};")
        lines.append("    for (j = 0; j < rows; j++) {")
        lines.append("        loops_ = 0;")
        for k, d in enumerate(inputs):
            lines.append(f"        {_cname(d.name)} = (({self._io_type(d)} *)in[{k}])[j];")
        for d in temps if self.checked else ():
            lines.append(f"        memset(&w_{_cname(d.name)}, 0, sizeof w_{_cname(d.name)});")
        for name in self.program.per_call:
            lines.append(f"        {_cname(name)} = 1;")
        lines += self.stmts(self.program.body, "        ")
        for k, d in enumerate(outputs):
            lines.append(f"        (({self._io_type(d)} *)out[{k}])[j] = ({self._io_type(d)}){_cname(d.name)};")
        lines.append("    }")
        lines.append("    j = -1;")
        lines.append("fail:")
        for d in memory:
            if not d.type.bounds:
                lines.append(f"    s->{_cname(d.name)} = {_cname(d.name)};")
        lines += ["    status[0] = fetestexcept(FE_INVALID | FE_DIVBYZERO | FE_OVERFLOW | FE_UNDERFLOW) != 0;",
                  "#if defined(__SSE__)", "    if (_mm_getcsr() & 0x2u) status[0] = 1;  /* a subnormal operand */",
                  "#endif", "    status[1] = j;", "    return j;", "}"]
        return "\n".join(lines) + "\n"

    def _io_type(self, d: s.VarDecl) -> str:
        return {"REAL": "float", "BOOL": "unsigned char"}.get(d.type.base, "int32_t")


IO_DTYPES = {"REAL": np.float32, "BOOL": np.uint8}


def _compiler() -> list[str] | None:
    """The C compiler command: $CC (split like a shell would, so CC="gcc -O0" works), else cc, gcc, clang."""
    given = shlex.split(os.environ.get("CC") or "")
    if given and shutil.which(given[0]):
        return [shutil.which(given[0]), *given[1:]]
    for name in ("cc", "gcc", "clang"):
        if shutil.which(name):
            return [shutil.which(name)]
    return None


_LOADED: dict[str, ctypes.CDLL] = {}  # source hash -> library, for this process


def _compiler_identity(compiler: list[str]) -> list[str]:
    """The compiler as the cache key sees it: its real path, size and modification time (an upgrade is
    another compiler), beside the command as given."""
    info = os.stat(compiler[0])
    return [*compiler, os.path.realpath(compiler[0]), str(info.st_size), str(info.st_mtime_ns)]


def load_library(source: str) -> ctypes.CDLL:
    """`source` compiled and loaded: from the private cache of compiled blocks when this text was compiled
    before by this compiler with these flags (verifier/engines/native_cache.py, which never loads a library anyone
    else could have written, nor one whose bytes differ from those it stored or that lacks `SYMBOLS`), else
    built in a folder that mkdtemp creates for this user alone (0700, a fresh name), loaded, kept in the
    cache, and the folder removed, also when the compiler fails. Compiling costs about 0.15 s per block."""
    compiler = _compiler()
    if compiler is None:
        raise NativeUnavailable("no C compiler found (set CC, or install gcc)")
    flags = CFLAGS + (X86_FLAGS if _is_x86() else [])
    key = hashlib.sha256("\0".join([source, *flags, *_compiler_identity(compiler)]).encode()).hexdigest()
    if key in _LOADED:
        return _LOADED[key]
    library = native_cache.load(key, SYMBOLS)
    if library is None:
        library = _build(source, compiler, flags, key)
    _LOADED[key] = library
    return library


def _build(source: str, compiler: list[str], flags: list[str], key: str) -> ctypes.CDLL:
    folder = Path(tempfile.mkdtemp(prefix="thermoplc-native-"))
    try:
        c_file, built = folder / "block.c", folder / "block.so"
        c_file.write_text(source)
        try:
            result = subprocess.run([*compiler, *flags, "-o", str(built), str(c_file), "-lm"], capture_output=True,
                                    text=True, stdin=subprocess.DEVNULL)
        except OSError as exc:
            raise NativeUnavailable(f"the C compiler {compiler[0]} cannot run: {exc}") from None
        if result.returncode != 0 or not built.exists():
            said = (result.stderr.strip() or result.stdout.strip())[:400] or "no message"
            raise NativeUnavailable(f"the C compiler {' '.join(compiler)} failed (exit {result.returncode}): {said}")
        library = ctypes.CDLL(str(built))
        native_cache.store(key, built)
        return library
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def _is_x86() -> bool:
    import platform
    return platform.machine().lower() in ("x86_64", "amd64", "i686", "i386")


class NativeBlock:
    """One block instance running natively; state persists between chunks like the FB's memory."""

    def __init__(self, program: s.Program, checked: bool = True):
        self.program = program
        self.inputs = [d for d in program.decls if d.section == "input"]
        self.outputs = [d for d in program.decls if d.section == "output"]
        if any(d.type.bounds for d in (*self.inputs, *self.outputs)):
            raise NativeUnavailable("array inputs or outputs")
        self.source = _Translator(program, checked).source()
        self.lib = load_library(self.source)
        self.lib.run.restype = ctypes.c_int64
        self.lib.run.argtypes = [ctypes.c_void_p, ctypes.c_int64, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_void_p]
        self.lib.state_size.restype = ctypes.c_int64
        self.state = ctypes.create_string_buffer(int(self.lib.state_size()))
        self.reset()

    def reset(self) -> None:
        self.lib.state_init(self.state)

    def run(self, columns: dict, rows: int) -> tuple[dict, bool] | None:
        """One call per row. Returns (outputs by name, FPU flags raised) or None when a row
        could not run natively (the caller replays with the interpreter)."""
        upper = {k.upper(): v for k, v in columns.items()}
        unwired = {d.name.upper(): np.full(rows, d.initial) for d in self.inputs  # keeps its start value, as on a PLC
                   if d.name.upper() not in upper and d.initial is not None}
        upper.update(unwired)
        ins = [np.ascontiguousarray(upper[d.name.upper()], IO_DTYPES.get(d.type.base, np.int32)) for d in self.inputs]
        outs = [np.empty(rows, IO_DTYPES.get(d.type.base, np.int32)) for d in self.outputs]
        in_ptrs = (ctypes.c_void_p * max(len(ins), 1))(*[a.ctypes.data for a in ins])
        out_ptrs = (ctypes.c_void_p * max(len(outs), 1))(*[a.ctypes.data for a in outs])
        status = np.zeros(STATUS_FLAGS, np.int64)
        stopped = self.lib.run(self.state, rows, in_ptrs, out_ptrs, status.ctypes.data)
        if stopped >= 0:
            return None
        result = {}
        for d, values in zip(self.outputs, outs):
            result[d.name] = values.astype(bool) if d.type.base == "BOOL" else values
        return result, bool(status[0])


def native_or_reason(program: s.Program) -> tuple[NativeBlock | None, str]:
    try:
        return NativeBlock(program), ""
    except NativeUnavailable as exc:
        return None, str(exc)
    except OSError as exc:
        return None, f"cannot load the compiled block: {exc}"
