"""Reading a case: TOML, ``extends`` merging, ``--set`` overrides, validation into a
:class:`~fsi_sph.config.model.Config` with errors that name the file and key path
(:class:`~fsi_sph.errors.ConfigError`)."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path
from typing import Any

from pydantic import BaseModel, ValidationError

from fsi_sph.config.model import Config
from fsi_sph.config.numerics import pick_numerics
from fsi_sph.errors import ConfigError


def _read_toml(path: Path, included_from: str | None) -> dict:
    where = f" (extends of {included_from})" if included_from else ""
    if not path.exists():
        raise ConfigError(f"{path}: file not found{where}")
    if path.is_dir():
        raise ConfigError(f"{path}: is a directory, expected a .toml case file{where}")
    try:
        raw = path.read_bytes()
    except OSError as e:
        raise ConfigError(f"{path}: cannot read file{where}: {e.strerror}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise ConfigError(f"{path}: not a UTF-8 text file{where}") from None
    return _parse_toml(text, str(path))


def _parse_toml(text: str, label: str) -> dict:
    if not text.strip():
        raise ConfigError(f"{label}: file is empty; a case needs at least a [case] table")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{label}: TOML syntax error: {e}") from None
    if not data:
        raise ConfigError(f"{label}: file has no keys or tables; a case needs at least a "
                          "[case] table")
    return data


def _merge(base: dict, top: dict) -> dict:
    """Deep merge: tables merge key by key, everything else in ``top`` replaces ``base``."""
    out = dict(base)
    for k, v in top.items():
        if isinstance(v, dict) and isinstance(out.get(k), dict):
            out[k] = _merge(out[k], v)
        else:
            out[k] = v
    return out


def _resolve_extends(data: dict, path: Path | None, stack: tuple[Path, ...]) -> dict:
    ext = data.pop("extends", None)
    if ext is None:
        return data
    label = str(path) if path else "<text>"
    if isinstance(ext, str):
        ext = [ext]
    if not isinstance(ext, list) or not all(isinstance(e, str) for e in ext):
        raise ConfigError(f"{label}: extends: expected a file name or a list of file names")
    base: dict = {}
    for e in ext:
        parent = path.parent if path else Path.cwd()
        target = (parent / e).resolve()
        if target in stack:
            chain = " -> ".join(str(p) for p in (*stack, target))
            raise ConfigError(f"{label}: extends: cycle: {chain}")
        sub = _read_toml(target, label)
        sub = _resolve_extends(sub, target, (*stack, target))
        base = _merge(base, sub)
    return _merge(base, data)


def _parse_value(text: str) -> Any:
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def apply_overrides(data: dict, overrides: list[str], label: str) -> dict:
    """Apply ``key.path=value`` overrides to the raw (merged) table."""
    data = json.loads(json.dumps(data))  # deep copy of plain TOML data
    for item in overrides:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key or any(not part for part in key.split(".")):
            raise ConfigError(f"--set {item!r}: expected KEY.PATH=VALUE, e.g. case.dx=0.002")
        node = data
        parts = key.split(".")
        for part in parts[:-1]:
            nxt = node.setdefault(part, {})
            if not isinstance(nxt, dict):
                raise ConfigError(f"{label}: --set {key}: {part!r} is a value, not a table")
            node = nxt
        node[parts[-1]] = _parse_value(value.strip())
    return data


def _allowed_keys(loc: tuple) -> list[str] | None:
    """Field names allowed in the table that holds ``loc[-1]`` (None if unknown)."""
    ann: Any = Config
    for part in loc[:-1]:
        ann = _child(ann, part)
        if ann is None:
            return None
    model = _inner_model(ann)
    return sorted(model.model_fields) if model is not None else None


def _child(ann: Any, part: Any) -> Any:
    """The annotation of item ``part`` (a field name, dict key or list index) of ``ann``."""
    meta = getattr(ann, "__metadata__", None)
    if meta is not None:  # Annotated[X, ...]
        return _child(ann.__origin__, part)
    if isinstance(ann, type) and issubclass(ann, BaseModel):
        field = ann.model_fields.get(part) if isinstance(part, str) else None
        return field.annotation if field is not None else None
    origin = getattr(ann, "__origin__", None)
    args = getattr(ann, "__args__", ())
    if origin is dict:
        return args[1]
    if origin in (list, tuple):
        return args[0]
    for a in args:  # unions: the first member that has this item
        c = _child(a, part)
        if c is not None:
            return c
    return None


def _inner_model(annotation: Any) -> Any:
    """Unwrap list[...], dict[..., M], Optional[M], Annotated[M, ...] down to a model class."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    if getattr(annotation, "__metadata__", None) is not None:
        return _inner_model(annotation.__origin__)
    for a in reversed(getattr(annotation, "__args__", ())):
        m = _inner_model(a)
        if m is not None:
            return m
    return None


def _format_errors(err: ValidationError, label: str, data: dict) -> str:
    lines = []
    for e in err.errors():
        loc = tuple(p for p in e["loc"] if p not in ("cantilever_mode", "uniform", "Shape",
                                                      "Polygon", "Circle"))
        path = ".".join(str(p) if not isinstance(p, int) else f"[{p}]" for p in loc)
        path = path.replace(".[", "[")
        msg = e["msg"]
        if e["type"] == "extra_forbidden":
            allowed = _allowed_keys(loc)
            what = "table" if isinstance(e.get("input"), dict) else "key"
            msg = f"unknown {what}" + (f"; allowed: {', '.join(allowed)}" if allowed else "")
        elif e["type"] == "missing":
            msg = "required " + ("table" if loc and loc[-1] in ("case", "material") else "key")
            msg += " is missing"
        elif e["type"] == "value_error":
            msg = msg.removeprefix("Value error, ")
        else:
            got = e.get("input")
            if not isinstance(got, dict):
                msg += f" (got {json.dumps(got)})"
        lines.append(f"{label}: {path}: {msg}" if path else f"{label}: {msg}")
    return "\n".join(lines)


def load_config(path: str | Path | None, overrides: list[str] | None = None,
                text: str | None = None) -> Config:
    """Read, merge (``extends``), override and validate a case.

    Parameters
    ----------
    path : the case file; ``None`` with ``text`` to parse a string.
    overrides : ``["key.path=value", ...]`` applied after ``extends``.
    text : TOML source used instead of reading ``path``.

    Raises
    ------
    ConfigError : with a message naming the file, the key path and what is allowed.
    """
    if text is not None:
        label = str(path) if path else "<text>"
        data = _parse_toml(text, label)
        p = Path(path).resolve() if path else None
    else:
        p = Path(path).resolve()
        label = str(path)
        data = _read_toml(p, None)
    data = _resolve_extends(data, p, (p,) if p else ())
    data = apply_overrides(data, overrides or [], label)
    case = data.get("case")
    if isinstance(case, dict) and "name" not in case and p is not None:
        case["name"] = p.stem
    for k in ("t_end", "dx"):  # catch NaN/inf that TOML allows
        v = case.get(k) if isinstance(case, dict) else None
        if isinstance(v, float) and not math.isfinite(v):
            raise ConfigError(f"{label}: case.{k}: must be a finite number (got {v})")
    return _validate(data, label)


def _validate(data: dict, label: str) -> Config:
    """The typed config of the raw table, with the physics-dependent numerics filled in
    (:mod:`fsi_sph.config.numerics`); what was filled is kept on the config
    (:meth:`Config.numerics_picked`)."""
    data, picks = pick_numerics(data)
    try:
        cfg = Config.model_validate_json(json.dumps(data), strict=True)
    except ValidationError as e:
        raise ConfigError(_format_errors(e, label, data)) from None
    except ValueError as e:  # json cannot encode NaN/inf comparisons etc.
        raise ConfigError(f"{label}: {e}") from None
    cfg.remember_picks(picks)
    return cfg


def load_config_from_run(run_file, overrides: list[str] | None = None) -> Config:
    """The config stored in a run file (``fsi-sph run --restart RUN.h5`` without a case),
    with ``overrides`` applied (e.g. a later ``case.t_end``)."""
    from fsi_sph.output import read_config

    label = f"{run_file} (stored config)"
    try:
        data = json.loads(read_config(run_file))
    except (OSError, KeyError, ValueError) as e:
        raise ConfigError(f"{run_file}: cannot read the config stored in the run file: {e}") \
            from None
    data = apply_overrides(data, overrides or [], label)
    return _validate(data, label)
