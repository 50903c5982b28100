"""User-written YAML specs as validated pydantic models: one module per part specified, named after it
(:mod:`~vinecli.specs.vehicle`, :mod:`~vinecli.specs.sprayer`, :mod:`~vinecli.specs.wind`,
:mod:`~vinecli.specs.mission`, :mod:`~vinecli.specs.canopy`: the names repeat those of the models of the same
part on purpose), their limits (:mod:`~vinecli.specs.limits`) and references between files
(:mod:`~vinecli.specs.refs`). May import the ground floor only.

``load_spec(path, Model)`` reads YAML with ``safe_load``, resolves ``base:`` inheritance
(a path relative to the file, or a bare name looked up in the same folder; the child's keys
are deep-merged over the base's), validates, and turns every problem into one
:class:`~vinecli.errors.SpecError` line naming the file and the field.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, TypeVar

import yaml
from pydantic import BaseModel, ConfigDict, ValidationError

from vinecli.errors import InputError, SpecError
from vinecli.inputs import note_input, read_input_text

#: libyaml's C parser and emitter when PyYAML was built with it (~20× faster than the pure-Python ones)
YAML_LOADER: type[yaml.SafeLoader] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
YAML_DUMPER: type[yaml.SafeDumper] = getattr(yaml, "CSafeDumper", yaml.SafeDumper)

M = TypeVar("M", bound=BaseModel)


#: most values a spec file may expand to (YAML aliases counted every time they are used)
MAX_YAML_VALUES = 1_000_000
#: largest spec file read, bytes
MAX_YAML_BYTES = 64 << 20


class StrictModel(BaseModel):
    """Base for every spec: unknown keys are errors (typos must not pass silently), and so are
    NaN and ±inf in any number field."""

    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


def read_yaml(path: Path) -> dict[str, Any]:
    """Read a YAML mapping (noted as an input of the running command, :mod:`vinecli.inputs`); SpecError if
    missing, not a regular file (a FIFO is refused without blocking), unreadable, invalid YAML or not a
    mapping. Messages never quote the file's content."""
    path = Path(path)
    try:
        text = read_input_text(path, "spec file", max_bytes=MAX_YAML_BYTES)
    except InputError as exc:
        raise SpecError(exc.problem.replace("spec file not found", "file not found"), path=path) from None
    note_input(path, "spec")
    try:
        data = yaml.load(text, Loader=YAML_LOADER)  # noqa: S506 - a safe loader
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        problem = getattr(exc, "problem", None) or str(exc).splitlines()[0]
        raise SpecError(f"invalid YAML{where}: {problem}", path=path) from None
    except RecursionError:
        raise SpecError("invalid YAML: nested too deeply", path=path) from None
    if data is None:
        raise SpecError("file is empty", path=path)
    if not isinstance(data, dict):
        raise SpecError(f"expected a mapping at the top level, got {type(data).__name__}", path=path)
    try:
        expanded_size(data, MAX_YAML_VALUES)
    except ValueError as exc:
        raise SpecError(str(exc), path=path) from None
    except RecursionError:
        raise SpecError("invalid YAML: nested too deeply", path=path) from None
    return data


def expanded_size(data: Any, limit: int) -> int:
    """Number of values ``data`` holds once every shared (aliased) part is counted each time it is used.

    Linear in the distinct containers (sizes are memoised by identity), so an alias bomb
    (``a: &a [x, x]``, ``b: &b [*a, *a]``...) is measured without being expanded. ValueError when the
    count exceeds ``limit`` or a container contains itself (a recursive alias).
    """
    sizes: dict[int, int] = {}
    active: set[int] = set()

    def size(obj: Any) -> int:
        if not isinstance(obj, (dict, list)):
            return 1
        key = id(obj)
        if key in sizes:
            return sizes[key]
        if key in active:
            raise ValueError("a YAML alias refers to itself (recursive structure)")
        active.add(key)
        items = [*obj.keys(), *obj.values()] if isinstance(obj, dict) else obj
        n = 1
        for item in items:
            n += size(item)
            if n > limit:
                raise ValueError(f"the file expands to more than {limit:,} values (YAML aliases: an alias bomb?)")
        active.discard(key)
        sizes[key] = n
        return n

    return size(data)


def deep_merge(base: dict[str, Any], over: dict[str, Any]) -> dict[str, Any]:
    """Recursively merge ``over`` into a copy of ``base`` (mappings merge, other values replace)."""
    out = dict(base)
    for k, v in over.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = deep_merge(out[k], v)
        else:
            out[k] = v
    return out


def _search_base(base: str, search: tuple[Path, ...]) -> Path | None:
    """The spec file ``base`` names inside one of the ``search`` folders (never outside them), or None."""
    for folder in search:
        root = folder.resolve()
        for cand in (root / base, root / f"{base}.yaml"):
            resolved = cand.resolve()
            if resolved.is_relative_to(root) and resolved.suffix in (".yaml", ".yml") and resolved.is_file():
                return resolved
    return None


def resolve_base(path: Path, data: dict[str, Any], _seen: tuple[Path, ...] = (),
                 search: tuple[Path, ...] = ()) -> dict[str, Any]:
    """Resolve a ``base:`` key (recursively) and return the merged mapping without it.

    The base is a spec file relative to ``path`` (``.yaml`` may be left out) inside the folders specs may
    refer to (:func:`vinecli.specs.refs.spec_reference`): ``base: /etc/shadow`` is refused unread. Not found
    there, it is looked up inside the ``search`` folders (e.g. the shipped vehicles for a fitted vehicle's
    ``base: x500``)."""
    from vinecli.specs.refs import spec_reference

    base = data.get("base")
    if base is None:
        return data
    data = {k: v for k, v in data.items() if k != "base"}
    if not isinstance(base, str) or not base:
        raise SpecError(f"base: expected a file name, got {type(base).__name__}", path=path)
    try:
        base_path = spec_reference(base, path, "base", try_suffix=True)
    except SpecError:
        base_path = _search_base(base, search)
        if base_path is None:
            raise
    if base_path in _seen:
        raise SpecError(f"base: {base!r} is circular", path=path)
    base_data = resolve_base(base_path, read_yaml(base_path), (*_seen, base_path), search)
    return deep_merge(base_data, data)


def format_validation_error(exc: ValidationError) -> str:
    """First validation problem as 'field.path: message' (plus how many more)."""
    errs = exc.errors()
    first = errs[0]
    loc = ".".join(str(p) for p in first["loc"]) or "(top level)"
    msg = first["msg"]
    if first["type"] == "extra_forbidden":
        msg = "unknown field"
    more = f" (and {len(errs) - 1} more problem{'s' if len(errs) > 2 else ''})" if len(errs) > 1 else ""
    return f"{loc}: {msg}{more}"


def validate_spec(model: type[M], data: dict[str, Any], path: Path | str) -> M:
    """Validate ``data`` against ``model``; SpecError naming ``path`` and the field."""
    try:
        return model.model_validate(data, context={"path": Path(path)})
    except ValidationError as exc:
        raise SpecError(format_validation_error(exc), path=path) from None


def load_spec(path: Path | str, model: type[M], base_dirs: tuple[Path, ...] = ()) -> M:
    """Read, resolve ``base:`` (next to the file, then in ``base_dirs``), and validate a YAML spec file."""
    path = Path(path)
    data = resolve_base(path.resolve(), read_yaml(path), search=base_dirs)
    return validate_spec(model, data, path)
