"""``wm check``: what the view of a graph on disk leaves out, who sent it, and deleting it.

It replays ``<data>/<graph>/`` the way ``wm serve`` does at start, lists every
entry of the document that the view rules leave out (docs/replication.md,
"Trust and validation") with the replica that sent it, and with ``repair``
deletes those entries from the document and compacts the files. The deletes
are ordinary CRDT deletes: the next time ``wm serve`` runs, every replica
receives them. Run it while ``wm serve`` is stopped: both would write the files.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path

from .errors import WMError
from .graph import Graph
from .ontology import Ontology
from .persistence import DiskLog
from .view_rules import LeftOut


class CheckError(WMError):
    """The data directory holds no such graph."""


@dataclass
class CheckReport:
    """What one check found (and, with ``repair``, deleted)."""

    nodes: int
    edges: int
    records: int
    left_out: list[LeftOut] = field(default_factory=list)
    repaired: bool = False

    def by_writer(self) -> Counter[str]:
        return Counter(entry.writer for entry in self.left_out)


def check(data_dir: str | Path, graph_name: str, ontology: Ontology | None = None, repair: bool = False) -> CheckReport:
    """Replay one graph from disk and report what its view leaves out; ``repair`` deletes it and compacts."""
    directory = Path(data_dir) / graph_name
    if not (directory / "snapshot.bin").exists() and not (directory / "log.bin").exists():
        raise CheckError(f"no graph {graph_name!r} under {data_dir} (expected {directory}/snapshot.bin or log.bin)")
    graph = Graph(ontology)
    disk = DiskLog(directory)
    try:
        records = disk.load_into(graph)
        report = CheckReport(graph.node_count(), len(graph.edges()), records, graph.left_out())
        if repair and report.left_out:
            graph.delete_left_out(report.left_out)
            disk.compact(graph)
            report.repaired = True
    finally:
        disk.close()
    return report
