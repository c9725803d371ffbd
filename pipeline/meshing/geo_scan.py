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

#: bare words that run programs, read other scripts, write or delete files, wait or exit
FORBIDDEN_COMMANDS = frozenset({
    "System", "SystemCall", "NonBlockingSystemCall", "OnelabRun", "OnelabAction",
    "SendToServer", "Include", "Merge", "MergeWithBoundingBox", "Save", "Print", "CreateDir",
    "DeleteFile", "RenameFile", "Sleep", "Exit", "Abort", "Plugin",
})
#: option groups that name executables or output files
FORBIDDEN_OPTION_GROUPS = frozenset({"Solver", "Print"})
_WRITERS = frozenset({"Printf", "Error", "Warning"})  # write to a file with "> file"
_WORD = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def _tokens(text: str):
    """(line, token) of the script's words and punctuation, comments and strings skipped."""
    i, n, line = 0, len(text), 1
    while i < n:
        c = text[i]
        if c == "\n":
            line += 1
            i += 1
        elif c.isspace():
            i += 1
        elif text.startswith("//", i):
            j = text.find("\n", i)
            i = n if j < 0 else j
        elif text.startswith("/*", i):
            j = text.find("*/", i + 2)
            j = n if j < 0 else j + 2
            line += text.count("\n", i, j)
            i = j
        elif c in "\"'":
            j = text.find(c, i + 1)
            j = n if j < 0 else j + 1
            line += text.count("\n", i, j)
            i = j
        else:
            m = _WORD.match(text, i)
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
    toks = list(_tokens(text))
    for k, (line, tok) in enumerate(toks):
        nxt = toks[k + 1][1] if k + 1 < len(toks) else ""
        why = None
        if tok in FORBIDDEN_COMMANDS:
            why = (f"the .geo command {tok!r} is not allowed (it runs programs, reads other "
                   "scripts, writes files or ends the process); a geometry needs none: "
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
