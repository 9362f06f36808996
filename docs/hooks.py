"""MkDocs hook: the reference pages, generated from the code at every build.

mkdocs.yml names this file under `hooks:`. At `on_files` it adds pages that exist only in the
build (nothing is written into docs/, so nothing can go stale):

- reference/config.md    the run configuration, walked from the pydantic schema (RunConfig):
                         every key with its type, default, limits and description;
- reference/material.md  the material file of `driver calibrate` (MaterialFile), the same way;
- reference/compare.md   the compare file of `driver compare` (CompareFile), the same way;
- reference/cli.md       every `driver` command with its arguments and options, from the
                         typer app (each parameter's help record, as `--help` prints it);
- reference/records.md   the record (thermo.dat) fields and the dump columns, from
                         runfiles/records.py (Record.describe(), Dump.describe());
- plugins/*.md           the plugin style pages, plugins/doc/*.md as they are, plus an index.

`python docs/hooks.py OUT_DIR` writes the same pages into OUT_DIR, to look at them without
building the site.

SOURCES says where each page comes from: when a module moves, change its line there.
"""

from __future__ import annotations

import html
import importlib
import inspect
import json
import re
import sys
import types
import typing
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent

#: Where each generated page comes from ("module:attribute", or a folder of the repository).
SOURCES = {
    "run config": "driver.config:RunConfig",
    "pairs": "driver.registry:units",
    "material file": "driver.calibration.material:MaterialFile",
    "compare file": "driver.compare.schema:CompareFile",
    "cli": "driver.cli:app",
    "cli main": "driver.cli:main",
    "records": "runfiles.records",
    "plugin docs": "plugins/doc",
}

#: Title of the nav section the plugin pages are listed under (mkdocs.yml).
PLUGIN_SECTION = "LAMMPS plugin styles"


def _load(spec: str) -> Any:
    if str(ROOT) not in sys.path:  # `mkdocs build` from a checkout without an installed package
        sys.path.insert(0, str(ROOT))
    module, _, attr = spec.partition(":")
    obj = importlib.import_module(module)
    return getattr(obj, attr) if attr else obj


# ---------------------------------------------------------------------------- markdown helpers
def _text(value: str) -> str:
    """Plain text for a table cell, on one line: outside code spans HTML escaped, Markdown's
    `|`, `*`, `_`, `\\`, `[`, `]` escaped and braces as entities (attr_list would read a cell
    ending in `{...}` as attributes); code spans as they are (a table keeps their pipes)."""
    parts = re.split(r"(`[^`]*`)", " ".join(str(value).split()))
    out = []
    for k, part in enumerate(parts):
        if k % 2:
            out.append(part)
        else:
            text = re.sub(r"([|*_\\\[\]])", r"\\\1", html.escape(part, quote=False))
            out.append(text.replace("{", "&#123;").replace("}", "&#125;"))
    return "".join(out)


def _code(value: str) -> str:
    """`value` as a code span (a table keeps the pipes inside a code span)."""
    return "`" + str(value) + "`"


def _table(header: list[str], rows: list[list[str]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def _number(value: float) -> str:
    """A number as a person writes it: 1e7, 0.005, 2.5e-5 (6 significant digits)."""
    if isinstance(value, bool) or not isinstance(value, float):
        return json.dumps(value)
    if value != 0 and (abs(value) >= 1e5 or abs(value) < 1e-3):
        mant, exp = f"{value:.5e}".split("e")
        return f"{mant.rstrip('0').rstrip('.')}e{int(exp)}"
    return f"{value:.6g}"


def _value(value: Any) -> str:
    """A default as it is written in YAML."""
    if value is None:
        return "null"
    if isinstance(value, (bool, int, float)):
        return _number(value)
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_value(v)}" for k, v in value.items()) + "}"
    return str(value)


# ------------------------------------------------------------------------ schema (pydantic)
def _models_in(annotation: Any) -> list[type]:
    """The pydantic model classes an annotation holds (through Optional, Union, Annotated, list, dict)."""
    from pydantic import BaseModel  # noqa: PLC0415

    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    out: list[type] = []
    for arg in typing.get_args(annotation):
        for m in _models_in(arg):
            if m not in out:
                out.append(m)
    return out


def _type_name(annotation: Any) -> str:
    """A short YAML-side name of a type: float, int, list[float], one of a, b, section, ..."""
    from pydantic import BaseModel  # noqa: PLC0415

    origin = typing.get_origin(annotation)
    args = typing.get_args(annotation)
    if origin is typing.Annotated:
        return _type_name(args[0])
    if origin is typing.Literal:
        return "one of " + ", ".join(_code(_value(a)) for a in args)
    if origin in (typing.Union, types.UnionType):
        names = [_type_name(a) for a in args if a is not type(None)]
        names = list(dict.fromkeys(names))
        return " or ".join(names) + (" or null" if type(None) in args else "")
    if origin in (list, tuple):
        inner = [a for a in args if a is not Ellipsis]
        if origin is tuple and len(inner) > 1:
            return "[" + ", ".join(_type_name(a) for a in inner) + "]"
        return f"list of {_type_name(inner[0])}" if inner else "list"
    if origin is dict:
        return f"mapping of {_type_name(args[1])}" if args else "mapping"
    if annotation is Any:
        return "any"
    if isinstance(annotation, type):
        if issubclass(annotation, BaseModel):
            return "section"
        if issubclass(annotation, Path):
            return "path"
        return {"str": "text", "bool": "true/false"}.get(annotation.__name__, annotation.__name__)
    return str(annotation)


_BOUNDS = (("gt", ">"), ("ge", "≥"), ("lt", "<"), ("le", "≤"), ("min_length", "length ≥"),
           ("max_length", "length ≤"), ("multiple_of", "multiple of"))


def _limits_of(metadata: list[Any]) -> list[str]:
    out = []
    for item in metadata:
        for attr, sign in _BOUNDS:
            value = getattr(item, attr, None)
            if value is not None:
                out.append(f"{sign} {_number(value)}")
        pattern = getattr(item, "pattern", None)
        if pattern is not None:
            out.append(f"matches {_code(pattern)}")
    return out


def _limits(field: Any) -> str:
    """The field's constraints (bounds, pattern) and those of a list's items."""
    out = [_text(t) if not t.startswith("matches") else t for t in _limits_of(field.metadata)]
    annotation = field.annotation
    for arg in typing.get_args(annotation):
        if typing.get_origin(arg) is typing.Annotated:
            items = [_text(t) for t in _limits_of(list(typing.get_args(arg)[1:]))]
            if items:
                out.append("items " + ", ".join(items))
    return ", ".join(out)


def _default(field: Any) -> str:
    """The default as shown: a YAML value, `required`, or a section's own defaults."""
    from pydantic import BaseModel  # noqa: PLC0415

    if field.is_required():
        return "required"
    if field.default_factory is not None:
        value = field.default_factory()
        if isinstance(value, BaseModel):
            return "its defaults"
        return _code(_value(value))
    return _code(_value(field.default))


def _anchor(path: str) -> str:
    return re.sub(r"[^a-z0-9]+", "-", path.lower()).strip("-")


def _doc(cls: type) -> str:
    doc = inspect.cleandoc(cls.__dict__.get("__doc__") or "")  # its own, not BaseModel's
    return " ".join(doc.split("\n\n")[0].split())


def _is_mapping(annotation: Any) -> bool:
    """A mapping of sections (`dict[str, Section]`, optional or not): its keys are names."""
    if typing.get_origin(annotation) is dict:
        return True
    return any(typing.get_origin(a) is dict for a in typing.get_args(annotation))


def _key(path: str, name: str, annotation: Any = None) -> str:
    """The dotted key of a field; `<name>` stands for the keys of a mapping of sections."""
    key = f"{path}.{name}" if path else name
    return f"{key}.<name>" if annotation is not None and _is_mapping(annotation) else key


def _sections(cls: type, path: str, anchor: str, title: str) -> list[tuple[str, str, str, type]]:
    """Every section below (and including) `cls`: (dotted path, anchor, title, class), depth first."""
    out = [(path, anchor, title, cls)]
    for name, field in cls.model_fields.items():
        models = _models_in(field.annotation)
        sub = _key(path, name, field.annotation)
        for m in models:
            kind = m.model_fields.get("kind")
            tag = f" (kind: {kind.default})" if len(models) > 1 and kind is not None else ""
            sub_anchor = _anchor(f"{anchor} {name} {kind.default if tag else ''}")
            out += _sections(m, sub, sub_anchor, f"{sub}{tag}")
    return out


def schema_page(root: type, title: str, intro: str, top: str = "top level") -> str:
    """A reference page of a pydantic schema: one table per section, every key of every section."""
    sections = _sections(root, "", "", top)
    links = {}  # (section path, class) -> anchor, for "see below" links
    for path, anchor, _, cls in sections:
        links.setdefault(path, []).append((cls, anchor))
    parts = [f"# {title}", "", intro, ""]
    for path, anchor, head, cls in sections:
        parts += [f"## {_text(head) if path else top.capitalize()} {{#{anchor or 'top-level'}}}", ""]
        if _doc(cls):
            parts += [_text(_doc(cls)), ""]
        rows = []
        for name, field in cls.model_fields.items():
            key = _key(path, name)
            default = _default(field)
            models = _models_in(field.annotation)
            kind = _type_name(field.annotation)
            if models:
                # one link per class: a section shared by two models (model.assembly) is listed once
                targets = list(dict(reversed(links.get(_key(path, name, field.annotation), []))).items())
                kind = ("mapping of " if _is_mapping(field.annotation) else "") + ", ".join(
                    f"[section{'' if len(targets) == 1 else ' (' + str(c.model_fields['kind'].default) + ')'}](#{a})"
                    for c, a in targets) + (" or null" if "null" in kind else "")
            rows.append([_code(key), kind if models else _text(kind), default, _limits(field),
                         _text(field.description or "")])
        parts += [_table(["key", "type", "default", "limits", "description"], rows), ""]
    return "\n".join(parts)


def config_page() -> str:
    run_config = _load(SOURCES["run config"])
    units = _load(SOURCES["pairs"])()
    pairs = _table(["model.kind", "scenario.kind", "what it runs"],
                   [[_code(m), _code(s), _text(u.description)] for (m, s), u in units.items()])
    intro = "\n\n".join([
        "Every key of a run configuration (`driver run FILE.yaml`), generated from the schema "
        f"(`{SOURCES['run config'].replace(':', '.')}` and the sections it joins) at each build of "
        "this site: the defaults, limits and descriptions below are the code's own. Unknown keys "
        "are errors; a default shown as `null` with \"filled in when the config is read\" is "
        "resolved from other keys and written to the run's `config.resolved.yaml`.",
        "`model:` and `scenario:` each hold one of several sections, chosen by their `kind`; a "
        "run is one registered pair:",
        pairs,
    ])
    return schema_page(run_config, "Configuration reference", intro)


def _module_doc(cls: type) -> str:
    """The docstring of the module that declares `cls` (an example file, indented: a code block)."""
    return inspect.getdoc(sys.modules[cls.__module__]) or ""


def material_page() -> str:
    cls = _load(SOURCES["material file"])
    intro = ("Every key of a material file (`driver calibrate MATERIAL.yaml`, [Calibration](../calibration.md)), "
             f"generated from the schema (`{SOURCES['material file'].replace(':', '.')}`) at each build of this "
             "site. Unknown keys are errors.\n\n" + _module_doc(cls))
    return schema_page(cls, "Material file reference", intro)


def compare_page() -> str:
    cls = _load(SOURCES["compare file"])
    intro = ("Every key of a compare file (`driver compare COMPARE.yaml`, [Comparing the models](../compare.md)), "
             f"generated from the schema (`{SOURCES['compare file'].replace(':', '.')}`) at each build of this "
             "site. Unknown keys are errors.\n\n" + _module_doc(cls))
    return schema_page(cls, "Compare file reference", intro)


# ------------------------------------------------------------------------------------- CLI
def _click_group(app: Any) -> Any:
    import typer.main  # noqa: PLC0415

    return typer.main.get_command(app)


def cli_commands() -> list[str]:
    """The names of the `driver` commands, in the order the CLI declares them."""
    return list(_click_group(_load(SOURCES["cli"])).commands)


def cli_page() -> str:
    group = _click_group(_load(SOURCES["cli"]))
    main = _load(SOURCES["cli main"])
    parts = ["# Command-line reference", "",
             f"Every `driver` command with its arguments and options, generated from the CLI "
             f"(`{SOURCES['cli'].replace(':', '.')}`) at each build of this site: the same text as "
             "`driver COMMAND --help`.", "",
             _text(group.help or ""), "", _text(" ".join((inspect.getdoc(main) or "").split())), "",
             _table(["command", "what it does"],
                    [[f"[`driver {name}`](#{_anchor('driver ' + name)})",
                      _text((cmd.help or "").split("\n\n")[0])] for name, cmd in group.commands.items()]), ""]
    for name, cmd in group.commands.items():
        ctx = cmd.make_context(name, [], resilient_parsing=True)
        usage = [f"driver {name}", "[OPTIONS]"]  # --help at least
        for p in cmd.params:
            if p.param_type_name == "argument":
                usage.append(p.name.upper() + ("..." if p.nargs == -1 else ""))
        rows = []
        for p in [*cmd.params, cmd.get_help_option(ctx)]:
            if p is None or getattr(p, "hidden", False):
                continue
            record = p.get_help_record(ctx)
            if record is None:  # an argument without help
                record = (p.name.upper(), "")
            names, help_text = record
            if p.param_type_name == "argument":  # as the usage line names it
                names = p.name.upper() + ("..." if p.nargs == -1 else "")
            rows.append([_code(names), _text(help_text)])
        parts += [f"## `driver {name}` {{#{_anchor('driver ' + name)}}}", "",
                  "```", " ".join(usage), "```", "", _text(" ".join((cmd.help or "").split())), "",
                  _table(["argument or option", "meaning"], rows), ""]
    return "\n".join(parts)


# --------------------------------------------------------------------------------- records
def records_of(module: Any) -> tuple[list[tuple[str, Any]], list[tuple[str, Any]]]:
    """([(variable, Record)], [(label, Dump)]) declared in the records module: every Record and
    Dump instance, and the dumps of every `*_dump(dimension)` function for 2 and 3."""
    records, dumps = [], []
    for name, obj in vars(module).items():
        if isinstance(obj, module.Record):
            records.append((name, obj))
        elif isinstance(obj, module.Dump):
            dumps.append((name, obj))
        elif inspect.isfunction(obj) and name.endswith("_dump") and obj.__module__ == module.__name__:
            for dim in (2, 3):
                dumps.append((f"{name}({dim})", obj(dim)))
    return records, dumps


def records_page() -> str:
    module = _load(SOURCES["records"])
    records, dumps = records_of(module)
    parts = ["# Records and dumps", "",
             f"What crosses from LAMMPS to the analysis, generated from `{module.__name__}` at each build "
             "of this site. Each field and column is declared there once, with its unit and meaning; the "
             "input templates print them and the analysis reads them by name.", "",
             _text(" ".join((module.__doc__ or "").split("\n\n")[1].split())) if (module.__doc__ or "").count(
                 "\n\n") else "", "",
             "## Records (`thermo.dat`)", "",
             "One `fix print` record per run, written every `scenario.thermo_every` steps into `thermo.dat`, "
             "its title line naming the fields.", ""]
    for var, rec in records:
        parts += [f"### `{rec.name}` {{#record-{_anchor(rec.name)}}}", "", f"`{module.__name__}.{var}`", "",
                  rec.describe(), ""]
    parts += ["## Dumps (`dumps/`)", "",
              "Atom dumps and `dump local` files, columns named so that OVITO maps them by itself.", ""]
    for var, dump in dumps:
        parts += [f"### `{dump.name}`: `{var}` {{#dump-{_anchor(var)}}}", "", dump.describe(), ""]
    return "\n".join(parts)


# --------------------------------------------------------------------------------- plugins
def plugin_docs() -> list[Path]:
    return sorted((ROOT / SOURCES["plugin docs"]).glob("*.md"))


def plugins_index() -> str:
    rows = []
    for path in plugin_docs():
        text = path.read_text()
        title = text.splitlines()[0].lstrip("# ").strip()
        body = text.split("\n\n")[1] if "\n\n" in text else ""
        first = " ".join(body.split()).split(". ")[0].rstrip(".") + "."
        rows.append([f"[`{title}`]({path.name})", _text(first)])
    return "\n".join([
        "# LAMMPS plugin styles", "",
        f"The styles of the project's LAMMPS plugin library (`plugins/src`, loaded with `plugin load "
        f"brittleplugin.so`; `driver plugins` builds it). One page per style, the files of "
        f"`{SOURCES['plugin docs']}/` as they are.", "",
        _table(["style", "what it is"], rows), ""])


# ------------------------------------------------------------------------------------ pages
def pages() -> dict[str, str]:
    """Every generated page: its path in the site's docs and its Markdown."""
    out = {
        "reference/config.md": config_page(),
        "reference/material.md": material_page(),
        "reference/compare.md": compare_page(),
        "reference/cli.md": cli_page(),
        "reference/records.md": records_page(),
        "plugins/index.md": plugins_index(),
    }
    for path in plugin_docs():
        out[f"plugins/{path.name}"] = path.read_text()
    return out


# ------------------------------------------------------------------------------ MkDocs events
def on_config(config: Any) -> Any:
    """List every plugin page under the nav section PLUGIN_SECTION (after its index)."""
    for item in config.nav or []:
        if isinstance(item, dict) and PLUGIN_SECTION in item:
            listed = item[PLUGIN_SECTION] if isinstance(item[PLUGIN_SECTION], list) else [item[PLUGIN_SECTION]]
            item[PLUGIN_SECTION] = listed + [f"plugins/{p.name}" for p in plugin_docs()
                                             if f"plugins/{p.name}" not in listed]
    return config


def on_files(files: Any, config: Any) -> Any:
    from mkdocs.structure.files import File  # noqa: PLC0415

    for src_uri, content in pages().items():
        files.append(File.generated(config, src_uri, content=content))
    return files


def on_serve(server: Any, config: Any, builder: Any) -> Any:
    """`mkdocs serve` rebuilds when the code the pages come from changes."""
    for folder in ("driver", "runfiles", SOURCES["plugin docs"]):
        server.watch(str(ROOT / folder))
    return server


if __name__ == "__main__":  # pragma: no cover - a look at the pages without building the site
    target = Path(sys.argv[1] if len(sys.argv) > 1 else "generated-docs")
    for rel, text in pages().items():
        (target / rel).parent.mkdir(parents=True, exist_ok=True)
        (target / rel).write_text(text)
        print(target / rel)
