"""Scenes as JSON: our own format, and import of DSR scene files.

Our format::

    {"format": "cortex-wm", "version": 1,
     "nodes": [{"id": 1, "type": "world", "name": "world", "attrs": {...}}],
     "edges": [{"src": 1, "dst": 2, "type": "RT", "attrs": {...}}]}

Bytes are written as ``{"$bytes": "<base64>"}``, and NaN or infinity (only
where the ontology entry allows them) as ``{"$float": "nan"}``, so the output
is always strict JSON. DSR's format (``{"DSRModel": ...}``) is read by
:mod:`wm.dsr_json`; attributes our ontology does not know are skipped and
listed in the :class:`LoadReport`, because DSR files carry many viewer-only
attributes. Unknown node or edge types are an error.

A load is checked in full before anything is written: either the whole scene
goes in, or nothing does.
"""

from __future__ import annotations

import base64
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from . import dsr_json
from .errors import NameExistsError, NodeExistsError, SceneFormatError, ValidationError

if TYPE_CHECKING:
    from .graph import Graph

FORMAT = "cortex-wm"
VERSION = 1


@dataclass
class LoadReport:
    """What a load inserted, and which attributes it skipped (DSR imports only)."""

    nodes: int = 0
    edges: int = 0
    skipped: list[str] = field(default_factory=list)
    id_map: dict[int, int] = field(default_factory=dict)


@dataclass
class _Scene:
    nodes: list[tuple[int, str, str, dict[str, Any]]]
    edges: list[tuple[int, int, str, dict[str, Any]]]
    skipped: list[str]


def encode_value(value: Any) -> Any:
    if isinstance(value, bytes):
        return {"$bytes": base64.b64encode(value).decode("ascii")}
    if isinstance(value, tuple):
        return [_encode_float(x) for x in value]
    if isinstance(value, float):
        return _encode_float(value)
    return value


def _encode_float(value: float) -> Any:
    """JSON has no NaN or infinity: an attribute whose ontology entry allows them writes ``{"$float": "nan"}``."""
    return value if math.isfinite(value) else {"$float": str(value)}


def _decode_value(value: Any) -> Any:
    if isinstance(value, Mapping) and set(value) == {"$bytes"}:
        return base64.b64decode(value["$bytes"])
    if isinstance(value, list):
        return [_decode_value(x) for x in value]
    if isinstance(value, Mapping) and set(value) == {"$float"} and value["$float"] in ("nan", "inf", "-inf"):
        return float(value["$float"])
    return value


def graph_to_dict(graph: Graph) -> dict[str, Any]:
    return {
        "format": FORMAT,
        "version": VERSION,
        "nodes": [
            {
                "id": n.id,
                "type": n.type,
                "name": n.name,
                "attrs": {k: encode_value(v) for k, v in sorted(n.attrs.items())},
            }
            for n in graph.nodes()
        ],
        "edges": [
            {
                "src": e.src,
                "dst": e.dst,
                "type": e.type,
                "attrs": {k: encode_value(v) for k, v in sorted(e.attrs.items())},
            }
            for e in graph.edges()
        ],
    }


def dumps(data: Mapping[str, Any], indent: int | None) -> str:
    return json.dumps(data, indent=indent, sort_keys=False, allow_nan=False)


def read_source(source: str | Path | Mapping[str, Any]) -> Mapping[str, Any]:
    """A parsed scene from a mapping, a JSON string or a file path."""
    if isinstance(source, Mapping):
        return source
    text: str
    if isinstance(source, Path) or (isinstance(source, str) and not source.lstrip().startswith("{")):
        try:
            text = Path(source).read_text(encoding="utf-8")
        except OSError as exc:
            raise SceneFormatError(f"{source}: cannot read the scene file: {exc.strerror}") from exc
    else:
        text = source
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise SceneFormatError(f"not valid JSON: {exc}") from exc
    if not isinstance(data, Mapping):
        raise SceneFormatError("a scene must be a JSON object")
    return data


def _parse_ours(data: Mapping[str, Any]) -> _Scene:
    if data.get("version") != VERSION:
        raise SceneFormatError(f"unsupported cortex-wm scene version {data.get('version')!r}")
    try:
        nodes = [
            (
                int(n["id"]),
                str(n["type"]),
                str(n["name"]),
                {k: _decode_value(v) for k, v in (n.get("attrs") or {}).items()},
            )
            for n in data.get("nodes", [])
        ]
        edges = [
            (
                int(e["src"]),
                int(e["dst"]),
                str(e["type"]),
                {k: _decode_value(v) for k, v in (e.get("attrs") or {}).items()},
            )
            for e in data.get("edges", [])
        ]
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise SceneFormatError(f"malformed cortex-wm scene: {exc!r}") from exc
    return _Scene(nodes, edges, [])


def _parse_dsr(graph: Graph, data: Mapping[str, Any]) -> _Scene:
    return _Scene(*dsr_json.parse(graph.ontology, data))


def parse(graph: Graph, data: Mapping[str, Any]) -> _Scene:
    if "DSRModel" in data:
        return _parse_dsr(graph, data)
    if data.get("format") == FORMAT:
        return _parse_ours(data)
    raise SceneFormatError("unknown scene format: expected {'format': 'cortex-wm', ...} or {'DSRModel': ...}")


def _check(graph: Graph, scene: _Scene, keep_ids: bool) -> None:
    """Everything that could refuse the scene, checked before the first write."""
    ontology = graph.ontology
    names: set[str] = set()
    ids: set[int] = set()
    for node_id, node_type, name, attrs in scene.nodes:
        ontology.check_attrs(ontology.node_type(node_type), attrs)
        if name in names:
            raise NameExistsError(f"scene node name {name!r} is used twice")
        graph.check_new_name(name)
        if node_id in ids:
            raise NodeExistsError(f"scene node id {node_id} is used twice")
        if keep_ids:
            try:
                graph.check_new_id(node_id)
            except (ValidationError, NodeExistsError) as exc:
                raise type(exc)(
                    f"{exc}; load the scene with fresh ids instead (wm load --new-ids, keep_ids=False)"
                ) from None
        names.add(name)
        ids.add(node_id)
    rt_parents: dict[int, int] = {}
    for src, dst, edge_type, attrs in scene.edges:
        ontology.check_attrs(ontology.edge_type(edge_type), attrs)
        for end in (src, dst):
            if end not in ids:
                raise SceneFormatError(
                    f"edge {src}-[{edge_type}]->{dst} refers to node {end}, which the scene does not define"
                )
        if edge_type == "RT":
            if rt_parents.setdefault(dst, src) != src:
                raise SceneFormatError(f"node {dst} has two RT parents in the scene")
    for start in rt_parents:
        seen, node = set(), start
        while node in rt_parents:
            if node in seen:
                raise SceneFormatError(f"the scene's RT edges form a cycle through node {node}")
            seen.add(node)
            node = rt_parents[node]


def load_into(graph: Graph, source: str | Path | Mapping[str, Any], keep_ids: bool) -> LoadReport:
    scene = parse(graph, read_source(source))
    _check(graph, scene, keep_ids)
    report = LoadReport(skipped=scene.skipped)
    with graph.batch():
        for node_id, node_type, name, attrs in scene.nodes:
            if keep_ids:
                graph.insert_node_with_id(node_id, node_type, name, attrs)
                report.id_map[node_id] = node_id
            else:
                report.id_map[node_id] = graph.insert_node(node_type, name, attrs)
            report.nodes += 1
        for src, dst, edge_type, attrs in scene.edges:
            graph.insert_or_assign_edge(report.id_map[src], report.id_map[dst], edge_type, attrs)
            report.edges += 1
    return report
