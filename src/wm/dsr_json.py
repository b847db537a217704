"""DSR scene files: reading them into a scene, and writing a graph the way DSR writes it.

DSR's layout is ``{"DSRModel": {"symbols": {"<id>": {"id": "<id>", "name",
"type", "attribute": {name: {"type": CODE, "value": ...}}, "links": [{"src",
"dst", "label", "linkAttribute": {...}}]}}}}``, with ids written as strings
and the type codes of :mod:`wm.dsr_codes`. :func:`graph_to_dsr` writes exactly
that, so DSR's own loader reads what we write.

Attributes the ontology does not allow on a type are skipped and listed (DSR
files carry viewer-only attributes); a node or edge type the ontology does not
declare is an error that names the packaged ontology declaring it, if any.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from typing import TYPE_CHECKING, Any

from . import dsr_codes
from .errors import SceneFormatError, UnknownAttributeError, UnknownTypeError
from .ontology import Ontology

if TYPE_CHECKING:
    from .graph import Graph

SceneNode = tuple[int, str, str, dict[str, Any]]
SceneEdge = tuple[int, int, str, dict[str, Any]]


def _check_type(ontology: Ontology, kind: str, type_name: str, where: str) -> None:
    if ontology.declares(kind, type_name):
        return
    packaged = [name for name in Ontology.packaged_declaring(kind, type_name) if name != ontology.source]
    hint = (
        f"use the ontology that declares it: --ontology {packaged[0]} (wm.Ontology.named({packaged[0]!r}))"
        if packaged
        else "no packaged ontology declares it: add it to your ontology file (docs/ontology.md)"
    )
    raise UnknownTypeError(
        f"{where} has {kind} type {type_name!r}, which ontology {ontology.source!r} does not declare; {hint}"
    )


def _attrs(ontology: Ontology, raw: Any, kind: str, type_name: str, where: str, skipped: list[str]) -> dict[str, Any]:
    if raw is None:
        return {}
    if not isinstance(raw, Mapping):
        raise SceneFormatError(f"{where}: attributes must be an object, got {type(raw).__name__}")
    element = ontology.node_type(type_name) if kind == "node" else ontology.edge_type(type_name)
    attrs: dict[str, Any] = {}
    for name, entry in raw.items():
        try:
            ontology.attribute_for(element, name)
        except UnknownAttributeError:
            skipped.append(f"{where}.{name}")
            continue
        if isinstance(entry, Mapping) and "type" in entry:
            attrs[name] = dsr_codes.from_json(entry["type"], entry.get("value"), f"{where}.{name}")
        else:
            attrs[name] = entry
    return attrs


def _node_id(value: Any, where: str) -> int:
    try:
        node_id = int(value)
    except (TypeError, ValueError):
        raise SceneFormatError(f"{where}: a node id must be an integer, got {value!r:.40}") from None
    if isinstance(value, bool) or node_id < 0:
        raise SceneFormatError(f"{where}: a node id must be a non-negative integer, got {value!r:.40}")
    return node_id


def parse(ontology: Ontology, data: Mapping[str, Any]) -> tuple[list[SceneNode], list[SceneEdge], list[str]]:
    """The nodes, edges and skipped attributes of a parsed DSR file; nothing is written here."""
    model = data["DSRModel"]
    symbols = model.get("symbols", model.get("symbol")) if isinstance(model, Mapping) else None
    if isinstance(symbols, Mapping):
        symbols = list(symbols.values())
    if not isinstance(symbols, list):
        raise SceneFormatError("DSRModel.symbols must be an object or a list of symbols")
    skipped: list[str] = []
    nodes: list[SceneNode] = []
    edges: list[SceneEdge] = []
    try:
        for symbol in symbols:
            node_id, node_type, name = _node_id(symbol["id"], "DSR symbol"), str(symbol["type"]), str(symbol["name"])
            where = f"node {name!r}"
            _check_type(ontology, "node", node_type, f"DSR scene {where}")
            nodes.append(
                (node_id, node_type, name, _attrs(ontology, symbol.get("attribute"), "node", node_type, where, skipped))
            )
            for link in symbol.get("links", []) or []:
                edge_type = str(link["label"])
                src, dst = _node_id(link["src"], where), _node_id(link["dst"], where)
                link_where = f"edge {src}-[{edge_type}]->{dst}"
                _check_type(ontology, "edge", edge_type, f"DSR scene {link_where}")
                edges.append(
                    (
                        src,
                        dst,
                        edge_type,
                        _attrs(ontology, link.get("linkAttribute"), "edge", edge_type, link_where, skipped),
                    )
                )
    except (KeyError, TypeError, AttributeError) as exc:
        raise SceneFormatError(f"malformed DSR scene: missing or wrong field {exc}") from exc
    return nodes, edges, skipped


def _encode_attrs(
    ontology: Ontology, element_kind: str, type_name: str, attrs: Mapping[str, Any], empty_vectors: bool
) -> dict[str, Any]:
    element = ontology.node_type(type_name) if element_kind == "node" else ontology.edge_type(type_name)
    encoded: dict[str, Any] = {}
    for name, value in sorted(attrs.items()):
        spec = ontology.attribute_for(element, name)
        kind = dsr_codes.dsr_type_of(spec.type, spec.length, spec.dsr, value)
        if empty_vectors and kind.name in ("float vector", "byte vector"):
            value = ()
        encoded[name] = dsr_codes.to_json(kind, value)
    return encoded


def graph_to_dsr(graph: Graph, skip_content: Collection[str] = ()) -> dict[str, Any]:
    """The graph in DSR's scene layout. Nodes of the types in ``skip_content`` are written without vector contents, as DSR does."""
    ontology = graph.ontology
    links: dict[int, list[dict[str, Any]]] = {}
    for edge in graph.edges():
        links.setdefault(edge.src, []).append(
            {
                "dst": str(edge.dst),
                "label": edge.type,
                "linkAttribute": _encode_attrs(ontology, "edge", edge.type, edge.attrs, False),
                "src": str(edge.src),
            }
        )
    symbols = {
        str(node.id): {
            "attribute": _encode_attrs(ontology, "node", node.type, node.attrs, node.type in skip_content),
            "id": str(node.id),
            "links": links.get(node.id, []),
            "name": node.name,
            "type": node.type,
        }
        for node in graph.nodes()
    }
    return {"DSRModel": {"symbols": symbols}}
