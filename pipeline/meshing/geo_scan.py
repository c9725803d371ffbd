"""Refuse ``.geo`` scripts that would run commands, touch files or end the process.

gmsh's scripting language can run shell commands (``SystemCall``), start solvers
(``OnelabRun``), read and parse other scripts (``Include``, ``Merge``), write files (``Save``,
``Print``, ``Printf(...) > "file"``, ``CreateDir``) and end the host process (``Exit``), and gmsh
offers no option to disable these. A geometry needs none of them, so a script that contains
one is refused before gmsh sees it, naming the file, the line and the command. The scan
reads the script as gmsh's lexer does: comments and quoted strings are skipped, commands are
bare words.
"""

from __future__ import annotations

import re
from pathlib import Path

from pipeline.core.errors import MeshError

__all__ = ["FORBIDDEN_COMMANDS", "FORBIDDEN_OPTION_GROUPS", "check_geo_script"]

#: bare words that run programs, read other scripts, write or delete files, wait, read the
#: terminal or exit
FORBIDDEN_COMMANDS = frozenset({
    "System", "SystemCall", "NonBlockingSystemCall", "OnelabRun", "OnelabAction",
    "SendToServer", "Include", "Merge", "MergeWithBoundingBox", "Save", "Print", "CreateDir",
    "DeleteFile", "RenameFile", "Sleep", "Exit", "Abort", "Plugin", "GetValue", "GetString",
})
#: the most passes a literal ``For`` loop may make (a geometry needs thousands at most)
MAX_LOOP = 1_000_000
_NUM = r"([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"
_FOR = re.compile(r"\bFor\s*(?:[A-Za-z_]\w*\s+In\s*)?[{(]\s*" + _NUM + r"\s*:\s*" + _NUM
                  + r"\s*(?::\s*" + _NUM + r"\s*)?[})]")
#: option groups that name executables or output files
FORBIDDEN_OPTION_GROUPS = frozenset({"Solver", "Print"})
_WRITERS = frozenset({"Printf", "Error", "Warning"})  # write to a file with "> file"
_WORD = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def _tokens(code: str):
    """(line, token) of the words and punctuation of a script whose comments and strings
    are blanked (:func:`_code`)."""
    i, n, line = 0, len(code), 1
    while i < n:
        c = code[i]
        if c == "\n":
            line += 1
            i += 1
        elif c.isspace():
            i += 1
        else:
            m = _WORD.match(code, i)
            if m:
                yield line, m.group()
                i = m.end()
            else:
                yield line, c
                i += 1


def check_geo_script(path: str | Path, where: str = "") -> None:
    """Raise MeshError ``file:line: what`` if the script holds a command that runs
    programs, reads other scripts, writes files or ends the process (``where``: what asked
    for the script, appended to the message)."""
    path = Path(path)
    tail = f" ({where})" if where else ""
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as exc:
        raise MeshError(f"{path}: not a UTF-8 text file (byte {exc.start}){tail}") from None
    code = _code(text)
    toks = list(_tokens(code))
    _check_loops(code, path, tail)
    _check_macros(toks, path, tail)
    for k, (line, tok) in enumerate(toks):
        nxt = toks[k + 1][1] if k + 1 < len(toks) else ""
        why = None
        if tok in FORBIDDEN_COMMANDS:
            why = (f"the .geo command {tok!r} is not allowed (it runs programs, reads other "
                   "scripts or the terminal, writes files or ends the process); a geometry "
                   "needs none: "
                   "inline included scripts, load CAD with recipe: step")
        elif tok in FORBIDDEN_OPTION_GROUPS and nxt == ".":
            why = f"the option group '{tok}.' is not allowed (it names executables or files)"
        elif tok in _WRITERS:
            depth = 0
            for _, t in toks[k + 1:]:
                depth += (t == "(") - (t == ")")
                if t == ";" and depth <= 0:
                    break
                if t == ">" and depth == 0:  # after the argument list: a redirection
                    why = f"'{tok}(...) > file' writes a file; not allowed"
                    break
        if why:
            raise MeshError(f"{path}:{line}: {why}{tail}")


def _code(text: str) -> str:
    """``text`` with comments and quoted strings blanked (newlines kept, so positions keep
    their lines)."""
    out, i, n = [], 0, len(text)
    while i < n:
        if text.startswith("//", i):
            j = text.find("\n", i)
            j = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
        elif text[i] in "\"'":
            j = text.find(text[i], i + 1)
            j = n if j < 0 else j + 1
        else:
            out.append(text[i])
            i += 1
            continue
        out.append("".join(c if c == "\n" else " " for c in text[i:j]))
        i = j
    return "".join(out)


def _check_loops(code: str, path: Path, tail: str) -> None:
    """A ``For`` loop over literal bounds that would make more than :data:`MAX_LOOP` passes
    (gmsh runs it in-process and cannot be stopped). Bounds that are expressions are not
    known before gmsh runs."""
    for m in _FOR.finditer(code):
        a, b = float(m.group(1)), float(m.group(2))
        step = float(m.group(3)) if m.group(3) else 1.0
        line = code.count("\n", 0, m.start()) + 1
        if step == 0:
            raise MeshError(f"{path}:{line}: a For loop with a zero step never ends{tail}")
        passes = (b - a) / step + 1
        if passes > MAX_LOOP:
            raise MeshError(f"{path}:{line}: a For loop of {passes:.3g} passes (at most "
                            f"{MAX_LOOP:g}){tail}")


def _check_macros(toks, path: Path, tail: str) -> None:
    """A ``Macro`` that calls itself, directly or through others: gmsh recurses until the
    process dies."""
    calls: dict[str, set[str]] = {}
    where: dict[str, int] = {}
    current = None
    for k, (line, tok) in enumerate(toks):
        nxt = toks[k + 1][1] if k + 1 < len(toks) else ""
        if tok == "Macro" and nxt:
            current = nxt
            calls.setdefault(current, set())
            where[current] = line
        elif tok == "Return":
            current = None
        elif tok == "Call" and current is not None and nxt:
            calls[current].add(nxt)
    for start, called in calls.items():
        seen, todo = set(), list(called)
        while todo:
            m = todo.pop()
            if m == start:
                raise MeshError(f"{path}:{where[start]}: macro {start!r} calls itself (through "
                                f"{sorted(called)}); gmsh would recurse until it dies"
                                f"{tail}")
            if m not in seen:
                seen.add(m)
                todo.extend(calls.get(m, ()))
