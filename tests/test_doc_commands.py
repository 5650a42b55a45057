"""Every command line quoted in the documentation still matches the code: a reader who copies a
documented command must not meet ``unrecognized arguments``.

The commands are read from ``README.md`` and ``docs/*.md`` (fenced and indented code blocks, a
trailing backslash continuing a line, and inline code spans, also across line breaks):
``python scripts/NAME.py ...`` and ``python benchmarks/NAME.py ...`` (after ``PYTHONPATH=src``,
``nice -n 10``, ``.venv/bin/python`` and the like; also a code span starting with
``scripts/NAME.py``), ``jamlab SUBCOMMAND ...`` and ``python -m jamlab SUBCOMMAND ...``. A
command ends with its code span or line, a shell operator (``;``, ``&&``, ``|``, ``>``, ``&``)
or a comment; what follows ``--`` is another program's (``fire_variant_run.py ... -- <jamlab run
options>``).

Each long option (``--flag``, ``=value`` stripped; values and placeholders such as ``CACHE`` or
``<before>/src`` are not looked at) must be one the command takes, checked statically from the
source (nothing is imported or run):

- a script: the file exists and ``"--flag"`` is a string of its source, of a module of
  ``scripts/`` or ``benchmarks/`` it imports (``bench_pressure.parse_sample_arguments``) or of a
  function it imports from jamlab (``jamlab.runs.add_run_arguments``); argparse's ``--help``;
- ``jamlab SUBCOMMAND``: the names of the ``typer.Option`` parameters of the function registered
  as that command in ``src/jamlab/cli`` (``ast``), checked against typer's own command below.

Files and options the documentation names as removed on purpose (history) are in ``REMOVED`` and
``REMOVED_OPTIONS``, each with its reason; keep them short.
"""

from __future__ import annotations

import ast
import functools
import re
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src"
CLI = SRC / "jamlab" / "cli"
SCRIPT_DIRS = ("scripts", "benchmarks")

REMOVED = {
    # docs/aqs.md tells the history of the AQS continuation: both scripts were removed with the
    # substep continuation (issue 14, commit 14b179c) and the text says so next to the command
    "scripts/aqs_continuation_check.py",
    "scripts/aqs_jamming_diagnostics.py",
    # docs/aqs.md, the minimiser tried in the third session and its removal (the same commit,
    # with spheres/newton.py)
    "benchmarks/bench_minimize.py",
}
"""Files the documentation names as removed on purpose: absent, their options unchecked."""

REMOVED_OPTIONS = {
    # docs/aqs.md, "Removed": the substep continuation's option, gone with it (commit 14b179c)
    "benchmarks/bench_aqs.py": {"--continuation"},
}
"""Options the documentation names as removed on purpose, per file."""

_OPERATORS = re.compile(r"&&|\|\||[;|&>]")
_PYTHON = re.compile(r"(\S*/)?python[0-9.]*")
_SCRIPT = re.compile(r"(?:\./)?(?:(scripts|benchmarks)/)?([A-Za-z0-9_]+)\.py")
_FLAG = re.compile(r"[\[(\"']*(--[A-Za-z0-9][A-Za-z0-9_-]*)")
_PREFIX = re.compile(r"[A-Za-z_]\w*=\S*|(\S*/)?(nice|time|env)|-\w|\d+|do|then|exec")
_SUBCOMMAND = re.compile(r"[a-z][a-z-]*(/[a-z][a-z-]*)*")
_PLACEHOLDER = re.compile(r"<[^<>]*>")  # <before>/src, <session start commit>/src
_SPAN = re.compile(r"(`+)(.+?)\1", re.DOTALL)


@dataclass(frozen=True)
class Command:
    """One documented command: where (``file:line``), what it runs (``scripts/x.py`` or
    ``jamlab shear``), its text and its long options."""

    where: str
    program: str
    text: str
    flags: tuple[str, ...]


# --- the documentation's code ------------------------------------------------------------------


def _joined(lines: list[tuple[int, str]]) -> list[tuple[int, str]]:
    """Code lines with a trailing backslash joined to the next, each at its first line."""
    out: list[tuple[int, str]] = []
    pending: tuple[int, str] | None = None
    for number, text in lines:
        if pending is not None:
            number, text = pending[0], pending[1] + " " + text.strip()
        if text.rstrip().endswith("\\"):
            pending = (number, text.rstrip()[:-1])
        else:
            pending = None
            out.append((number, text))
    if pending is not None:
        out.append(pending)
    return out


def code_pieces(path: Path) -> list[tuple[int, str]]:
    """``(line, text)`` of every piece of code in the markdown file ``path``: the logical lines
    of fenced and indented code blocks, and the inline code spans of the prose (a span may run
    over line breaks inside a paragraph)."""
    lines = path.read_text().splitlines()
    pieces: list[tuple[int, str]] = []
    block: list[tuple[int, str]] = []
    paragraph: list[tuple[int, str]] = []
    fence: str | None = None
    previous_blank, in_indented = True, False

    def flush_paragraph() -> None:
        if not paragraph:
            return
        text = "\n".join(t for _, t in paragraph)
        for m in _SPAN.finditer(text):
            line = paragraph[0][0] + text.count("\n", 0, m.start())
            pieces.append((line, m.group(2).replace("\n", " ")))
        paragraph.clear()

    def flush_block() -> None:
        pieces.extend(_joined(block))
        block.clear()

    for number, line in enumerate(lines, 1):
        stripped = line.strip()
        if fence is not None:
            if stripped.startswith(fence):
                fence = None
                flush_block()
            else:
                block.append((number, line))
            continue
        if stripped.startswith(("```", "~~~")):
            flush_paragraph()
            fence = stripped[:3]
            continue
        indented = line.startswith("    ") and stripped and "`" not in line
        if indented and (previous_blank or in_indented):
            # an indented code block (an indented line with code spans is a list's paragraph)
            flush_paragraph()
            in_indented = True
            block.append((number, line))
        elif not stripped:
            flush_paragraph()
            if not in_indented:
                flush_block()
        else:
            if in_indented:
                flush_block()
            in_indented = False
            paragraph.append((number, line))
        previous_blank = not stripped
    flush_paragraph()
    flush_block()
    return pieces


def _script(token: str) -> str | None:
    """``scripts/x.py`` for the token ``scripts/x.py``, ``benchmarks/x.py`` for
    ``benchmarks/x.py``; a bare ``x.py`` is the file of ``scripts/`` or ``benchmarks/`` with that
    name (``None`` when neither has it: not one of ours)."""
    m = _SCRIPT.fullmatch(token)
    if m is None:
        return None
    if m.group(1):
        return f"{m.group(1)}/{m.group(2)}.py"
    path = _sibling(m.group(2))
    return None if path is None else str(path.relative_to(ROOT))


def _starts_command(before: list[str]) -> bool:
    """Whether a command may start after the tokens ``before`` of its piece of code: at the
    start, after a shell operator, or after nothing but the environment and wrappers
    (``PYTHONPATH=src``, ``nice -n 10``, ``do``); not in ``from jamlab import x`` nor as a word
    of a sentence or of a program's output."""
    for token in reversed(before):
        if _OPERATORS.search(token[-1:]) or token in ("$", "("):
            return True
        if not _PREFIX.fullmatch(token):
            return False
    return True


def commands_in(text: str) -> list[tuple[str, list[str]]]:
    """``(program, arguments)`` of each command in the code ``text``: ``scripts/x.py`` or
    ``jamlab SUBCOMMAND`` (``jamlab`` alone when none follows), arguments up to the end of the
    command."""
    tokens = _PLACEHOLDER.sub("X", text).split()
    out: list[tuple[str, list[str]]] = []
    i = 0
    while i < len(tokens):
        token, after = tokens[i], tokens[i + 1:]
        program: str | None = None
        if _PYTHON.fullmatch(token) and after:
            if script := _script(after[0]):
                program, start = script, i + 2
            elif after[:2] == ["-m", "jamlab"]:
                program, start = "jamlab", i + 3
        elif (script := _script(token)) and _starts_command(tokens[:i]):
            program, start = script, i + 1  # `scripts/x.py --flag`, `tail_events.py RUN --n 500`
        elif (token == "jamlab" or token.endswith("/jamlab")) and _starts_command(tokens[:i]):
            program, start = "jamlab", i + 1
        if program is None:
            i += 1
            continue
        arguments = []
        for argument in tokens[start:]:
            if argument.startswith("#"):
                break
            cut = _OPERATORS.search(argument)
            if cut:
                if cut.start():
                    arguments.append(argument[: cut.start()])
                break
            arguments.append(argument)
        i = start + len(arguments)
        if program == "jamlab" and arguments and not arguments[0].startswith("-"):
            if not _SUBCOMMAND.fullmatch(arguments[0]):
                continue  # `jamlab 147abe367b8e`: a version in a program's output
            # `jamlab shear/run --volume-guess`: the option of both commands
            subcommands = arguments.pop(0).split("/")
            out += [(f"jamlab {name}", arguments) for name in subcommands]
        else:
            out.append((program, arguments))
    return out


def flags_of(arguments: list[str]) -> tuple[str, ...]:
    """The long options among ``arguments`` (``--flag=value`` as ``--flag``), up to ``--``."""
    flags = []
    for argument in arguments:
        if argument == "--":
            break
        m = _FLAG.match(argument)
        if m:
            flags.append(m.group(1))
    return tuple(flags)


def documented_commands() -> list[Command]:
    """Every command of ``README.md`` and ``docs/*.md``."""
    out = []
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]:
        for line, text in code_pieces(path):
            for program, arguments in commands_in(text):
                out.append(Command(f"{path.relative_to(ROOT)}:{line}", program,
                                   " ".join([program, *arguments]), flags_of(arguments)))
    return out


# --- what the code takes ---------------------------------------------------------------------


_QUOTED_FLAG = re.compile(r"""["'](--[A-Za-z0-9][\w-]*(?:/--[A-Za-z0-9][\w-]*)*)["']""")
_IMPORT = re.compile(r"^[ \t]*(?:from[ \t]+(\.*[\w.]*)[ \t]+import[ \t]+(\([^)]*\)|.*)"
                     r"|import[ \t]+([\w., \t]+))", re.MULTILINE)
_BY_FILE = re.compile(r"spec_from_file_location\(\s*[\"'](\w+)[\"']")
_DYNAMIC = re.compile(r"""f["']--\{""")
_WORD = re.compile(r"""["']([A-Za-z0-9][\w-]*)["']""")


def _flags(text: str) -> set[str]:
    """The quoted options of the source ``text`` (``"--a/--b"`` gives both)."""
    return {f for m in _QUOTED_FLAG.finditer(text) for f in m.group(1).split("/")}


def _imports(text: str) -> list[tuple[str, list[str]]]:
    """``(module, names)`` of the imports of the source ``text`` (``import m``: no names)."""
    out = []
    for m in _IMPORT.finditer(text):
        if m.group(3):
            out += [(x.split()[0], []) for x in m.group(3).split(",") if x.strip()]
        else:
            names = re.sub(r"#.*", "", m.group(2)).strip("() \t\n").split(",")
            out.append((m.group(1), [x.split()[0] for x in names if x.strip()]))
    return out


def _sibling(name: str) -> Path | None:
    """``scripts/<name>.py`` or ``benchmarks/<name>.py`` (a script puts both on its path)."""
    for d in SCRIPT_DIRS:
        path = ROOT / d / f"{name}.py"
        if path.is_file():
            return path
    return None


def _jamlab_definition(module: str, name: str, depth: int = 0) -> str:
    """The source of ``name`` imported from the jamlab module ``module`` (a function's or
    class's lines), followed through a package's re-exports (``from jamlab.runs import
    add_run_arguments`` is ``jamlab/runs/arguments.py``'s); empty when not found."""
    base = SRC / module.replace(".", "/")
    path = base / "__init__.py" if base.is_dir() else base.with_suffix(".py")
    if depth > 5 or not path.is_file():
        return ""
    text = path.read_text()
    start = re.search(rf"^(?:def|class) {re.escape(name)}\b", text, re.MULTILINE)
    if start:
        end = re.compile(r"^\S", re.MULTILINE).search(text, start.end())
        return text[start.start(): end.start() if end else len(text)]
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    for source, names in _imports(text):
        if name in names:
            if source.startswith("."):
                level = len(source) - len(source.lstrip("."))
                source = package.rsplit(".", level - 1)[0] + "." + source.lstrip(".")
            return _jamlab_definition(source.rstrip("."), name, depth + 1)
    return ""


@functools.cache
def _own_flags(path: Path) -> tuple[frozenset[str], tuple[Path, ...]]:
    """The options one file of ``scripts/`` or ``benchmarks/`` spells and the files of those
    directories it imports."""
    text = path.read_text()
    flags = _flags(text)
    siblings = [m.group(1) for m in _BY_FILE.finditer(text)]
    for module, names in _imports(text):
        siblings.append(module)
        if module.startswith("jamlab"):
            for name in names:
                flags |= _flags(_jamlab_definition(module, name))
    if _DYNAMIC.search(text):  # f"--{name}": any quoted word may be an option
        flags |= {f"--{m.group(1)}" for m in _WORD.finditer(text)}
    if "ArgumentParser(" in text:
        flags.add("--help")
    return frozenset(flags), tuple(p for p in map(_sibling, siblings) if p is not None)


@functools.cache
def script_flags(path: Path) -> frozenset[str]:
    """The ``"--flag"`` strings of the script ``path``, of the modules of ``scripts/`` and
    ``benchmarks/`` it imports (by ``import``, or by file with ``spec_from_file_location``) and
    of the functions it imports from jamlab (``jamlab.runs.add_run_arguments``). A script that
    spells its options ``f"--{name}"`` takes ``--x`` for any string ``"x"`` of its source."""
    flags: set[str] = set()
    todo, seen = [path], set()
    while todo:
        p = todo.pop()
        if p not in seen:
            seen.add(p)
            own, siblings = _own_flags(p)
            flags |= own
            todo += siblings
    return frozenset(flags)


def _option_names(call: ast.Call, parameter: str) -> set[str]:
    """The names of a ``typer.Option(...)`` for ``parameter`` (``"--a/--b"`` gives both; none
    given: ``--parameter-name``, as typer derives it)."""
    names = {
        s
        for a in call.args
        if isinstance(a, ast.Constant) and isinstance(a.value, str)
        for s in a.value.split("/")
        if s.startswith("--")
    }
    if any(isinstance(a, ast.Constant) and isinstance(a.value, str) and a.value.startswith("-")
           for a in call.args):
        return names  # short names only ("-q") are not long options
    return {"--" + parameter.replace("_", "-")}


def _typer_call(node: ast.AST | None, kind: str) -> ast.Call | None:
    """The ``typer.<kind>(...)`` call in a default or an ``Annotated[...]`` annotation."""
    for n in ast.walk(node) if node is not None else ():
        if isinstance(n, ast.Call) and isinstance(n.func, ast.Attribute) and n.func.attr == kind:
            return n
    return None


def _parameter_options(function: ast.FunctionDef, aliases: dict[str, set[str]]) -> set[str]:
    arguments = function.args.args + function.args.kwonlyargs
    defaults = [None] * (len(function.args.args) - len(function.args.defaults))
    defaults += function.args.defaults + function.args.kw_defaults
    out = {"--help"}
    for argument, default in zip(arguments, defaults, strict=True):
        annotation = argument.annotation
        if isinstance(annotation, ast.Name) and annotation.id in aliases:
            out |= aliases[annotation.id]
            continue
        option = _typer_call(annotation, "Option") or _typer_call(default, "Option")
        if option is not None:
            out |= _option_names(option, argument.arg)
        elif (default is not None and _typer_call(annotation, "Argument") is None
              and _typer_call(default, "Argument") is None
              and not (isinstance(annotation, ast.Attribute) and annotation.attr == "Context")):
            out.add("--" + argument.arg.replace("_", "-"))  # a plain parameter with a default
    return out


def cli_options() -> dict[str, set[str]]:
    """``{"jamlab shear": {"--dgamma", ...}, ...}`` read from ``src/jamlab/cli`` with ``ast``
    (``"jamlab"``: the options before a subcommand)."""
    trees = {p: ast.parse(p.read_text(), str(p)) for p in sorted(CLI.glob("*.py"))}
    aliases: dict[str, set[str]] = {}  # Force = Annotated[bool, typer.Option("--force")]
    for tree in trees.values():
        for node in tree.body:
            if isinstance(node, ast.Assign) and len(node.targets) == 1:
                option = _typer_call(node.value, "Option")
                if option is not None and isinstance(node.targets[0], ast.Name):
                    aliases[node.targets[0].id] = _option_names(option, node.targets[0].id)
    out: dict[str, set[str]] = {}
    for tree in trees.values():
        functions = {n.name: n for n in ast.walk(tree) if isinstance(n, ast.FunctionDef)}
        for function in functions.values():
            for decorator in function.decorator_list:
                if isinstance(decorator, ast.Call) and isinstance(decorator.func, ast.Attribute):
                    if decorator.func.attr == "callback":
                        out["jamlab"] = _parameter_options(function, aliases)
                    elif decorator.func.attr == "command":
                        name = _command_name(decorator, function.name)
                        out[f"jamlab {name}"] = _parameter_options(function, aliases)
        for node in ast.walk(tree):
            # app.command("name")(function)
            if (isinstance(node, ast.Call) and isinstance(node.func, ast.Call)
                    and isinstance(node.func.func, ast.Attribute)
                    and node.func.func.attr == "command" and node.args
                    and isinstance(node.args[0], ast.Name) and node.args[0].id in functions):
                function = functions[node.args[0].id]
                name = _command_name(node.func, function.name)
                out[f"jamlab {name}"] = _parameter_options(function, aliases)
    return out


def _command_name(call: ast.Call, function: str) -> str:
    if call.args and isinstance(call.args[0], ast.Constant):
        return call.args[0].value
    return function.replace("_", "-")


# --- the checks ------------------------------------------------------------------------------


def problems(commands: list[Command]) -> list[str]:
    """One line per documented command or option the code does not have."""
    cli = cli_options()
    out = []
    for c in commands:
        if c.program.startswith("jamlab"):
            known = cli.get(c.program)
            if known is None:
                out.append(f"{c.where}: `{c.text}`: no command {c.program!r}")
                continue
        else:
            if c.program in REMOVED:
                continue
            path = ROOT / c.program
            if not path.is_file():
                out.append(f"{c.where}: `{c.text}`: no file {c.program}")
                continue
            known = script_flags(path)
        removed = REMOVED_OPTIONS.get(c.program, set())
        out += [f"{c.where}: `{c.text}`: unknown option {f}" for f in c.flags
                if f not in known and f not in removed]
    return out


def test_documented_commands_match_the_code():
    commands = documented_commands()
    assert len(commands) > 100, "the documentation's commands were not found"
    bad = problems(commands)
    assert not bad, f"{len(bad)} documented command(s) the code refuses:\n" + "\n".join(bad)


def test_the_cli_options_read_statically_are_typers():
    """The ``ast`` reading of ``src/jamlab/cli`` against the options of typer's own commands."""
    import typer

    from jamlab.cli import app

    command = typer.main.get_command(app)
    real = {"jamlab": command} | {f"jamlab {n}": c for n, c in command.commands.items()}
    real_options = {
        name: {o for p in c.params for o in p.opts + p.secondary_opts if o.startswith("--")}
        | {"--help"}
        for name, c in real.items()
    }
    assert cli_options() == real_options


def test_the_removed_files_are_gone_and_still_mentioned():
    """The allowlists stay small: each entry is absent from the code and named in the docs."""
    commands = documented_commands()
    for name in REMOVED:
        assert not (ROOT / name).exists(), f"{name} exists: check it, drop it from REMOVED"
        assert any(c.program == name for c in commands), f"{name} is no longer mentioned"
    for name, flags in REMOVED_OPTIONS.items():
        assert not flags & script_flags(ROOT / name), f"{name} has {flags} again"
        assert any(c.program == name and flags & set(c.flags) for c in commands), name


def test_the_checker_catches_what_it_should(tmp_path):
    """The reader and the checker against known snippets (a check that cannot fail proves
    nothing)."""
    doc = tmp_path / "doc.md"
    doc.write_text(
        "Run `PYTHONPATH=src nice -n 5 python scripts/tail_events.py RUN --n 500\n"
        "--above 1e-9` (one span over two lines) or `jamlab shear/run --volume-guess`.\n"
        "\n"
        "    PYTHONPATH=src python benchmarks/bench_pressure.py --n 1000 --seeds 1 \\\n"
        "        --old-src <before>/src --cache CACHE && python scripts/nothing.py --x\n"
        "\n"
        "```\n"
        "from jamlab import shear\n"
        "python -m jamlab prepare --n 32 --phi=0.8 --seeds 1 > log 2>&1\n"
        "python scripts/fire_variant_run.py --fire dt_max=0.1 -- --phi jamming --n 250\n"
        "  machine 1: numpy 2.4.6; jamlab 147abe367b8e\n"
        "```\n"
    )
    pieces = code_pieces(doc)
    assert [line for line, _ in pieces] == [1, 2, 4, 8, 9, 10, 11]
    found = [(program, flags_of(arguments)) for _, text in pieces
             for program, arguments in commands_in(text)]
    assert found == [
        ("scripts/tail_events.py", ("--n", "--above")),
        ("jamlab shear", ("--volume-guess",)),
        ("jamlab run", ("--volume-guess",)),
        ("benchmarks/bench_pressure.py", ("--n", "--seeds", "--old-src", "--cache")),
        ("scripts/nothing.py", ("--x",)),
        ("jamlab prepare", ("--n", "--phi", "--seeds")),
        ("scripts/fire_variant_run.py", ("--fire",)),
    ]
    commands = [Command(f"doc.md:{i}", program, program, flags)
                for i, (program, flags) in enumerate(found)]
    assert problems(commands) == [
        "doc.md:4: `scripts/nothing.py`: no file scripts/nothing.py",
        "doc.md:5: `jamlab prepare`: unknown option --seeds",
    ]
    # options spelled by a shared parser or built as f"--{name}"
    assert "--n" in script_flags(ROOT / "scripts" / "extensivity.py")  # jamlab.runs
    assert "--cache" in script_flags(ROOT / "scripts" / "newton_failure_anatomy.py")
    assert "--every" in script_flags(ROOT / "scripts" / "fire_line_probe.py")
    assert "--every" not in script_flags(ROOT / "scripts" / "tail_events.py")
