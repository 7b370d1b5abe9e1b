"""A picture of the running graph, like rqt_graph: nodes, topics and who talks to whom.

Nodes are ellipses, topics are boxes, and each edge goes publisher → topic →
subscriber. The layout is layered and deterministic (same graph, same picture): a
node or topic sits one column right of the furthest thing that feeds it, and each
column is ordered by the mean row of what feeds it. The SVG is written directly, so
no Graphviz is needed. Like rqt_graph, ``/rosout``, ``/parameter_events`` and hidden
nodes and topics are left out unless asked for.
"""

from __future__ import annotations

from dataclasses import dataclass
from html import escape

from rclpy.node import Node

from rosbook.runtime.graph import is_hidden, node_names, observer

#: Topics every node has; rqt_graph hides them by default ("Hide: Debug").
DEBUG_TOPICS = frozenset({"/rosout", "/parameter_events"})

CHAR_W = 7.4  # average glyph width of 12 px sans-serif text
ROW_H = 56
COL_GAP = 70
MARGIN = 16
BOX_H = 30
ROUTE_GAP = 12  # clearance of an edge that passes other columns


@dataclass(frozen=True)
class GraphEdges:
    """The graph as vertices and edges; a vertex is ``('node'|'topic', name)``."""

    nodes: list[str]
    topics: list[str]
    edges: list[tuple[tuple[str, str], tuple[str, str]]]


def collect(
    node: Node | None = None, *, include_hidden: bool = False, include_debug: bool = False
) -> GraphEdges:
    """Read who publishes and subscribes what from the live graph."""
    watcher = observer(node)
    names = node_names(watcher, include_hidden=include_hidden)
    edges: set[tuple[tuple[str, str], tuple[str, str]]] = set()
    topics: set[str] = set()

    def keep(topic: str) -> bool:
        hidden = is_hidden(topic) and not include_hidden
        return not hidden and (include_debug or topic not in DEBUG_TOPICS)

    for fq in names:
        namespace, _, name = fq.rpartition("/")
        namespace = namespace or "/"
        for topic, _ in watcher.get_publisher_names_and_types_by_node(name, namespace):
            if keep(topic):
                topics.add(topic)
                edges.add((("node", fq), ("topic", topic)))
        for topic, _ in watcher.get_subscriber_names_and_types_by_node(name, namespace):
            if keep(topic):
                topics.add(topic)
                edges.add((("topic", topic), ("node", fq)))
    return GraphEdges(nodes=names, topics=sorted(topics), edges=sorted(edges))


def _layers(g: GraphEdges) -> dict[tuple[str, str], int]:
    """Longest-path layering after breaking cycles by a depth-first search in name order."""
    vertices = [("node", n) for n in g.nodes] + [("topic", t) for t in g.topics]
    succ: dict[tuple[str, str], list[tuple[str, str]]] = {v: [] for v in vertices}
    for a, b in g.edges:
        succ[a].append(b)
    state: dict[tuple[str, str], int] = {}
    order: list[tuple[str, str]] = []
    forward: set[tuple[tuple[str, str], tuple[str, str]]] = set()

    def visit(v: tuple[str, str]) -> None:
        state[v] = 1
        for w in sorted(succ[v]):
            if state.get(w) == 1:
                continue  # a back edge: ignored for layering
            forward.add((v, w))
            if w not in state:
                visit(w)
        state[v] = 2
        order.append(v)

    indegree = {v: 0 for v in vertices}
    for _, b in g.edges:
        indegree[b] += 1
    for v in sorted(vertices, key=lambda v: (indegree[v] > 0, v[0] == "topic", v[1])):
        if v not in state:
            visit(v)
    layer = {v: 0 for v in vertices}
    for v in reversed(order):  # topological order of the forward edges
        for w in succ[v]:
            if (v, w) in forward:
                layer[w] = max(layer[w], layer[v] + 1)
    return layer


def _label_width(v: tuple[str, str]) -> float:
    return len(v[1]) * CHAR_W + (34 if v[0] == "node" else 20)


def to_svg(g: GraphEdges, title: str = "ROS graph") -> str:
    """The SVG text of ``g``'s picture."""
    layer = _layers(g)
    columns: dict[int, list[tuple[str, str]]] = {}
    for v in sorted(layer, key=lambda v: (v[0], v[1])):
        columns.setdefault(layer[v], []).append(v)
    preds: dict[tuple[str, str], list[tuple[str, str]]] = {}
    for a, b in g.edges:
        preds.setdefault(b, []).append(a)
    row: dict[tuple[str, str], float] = {}
    for c in sorted(columns):

        def key(v: tuple[str, str]) -> tuple[float, str]:
            placed = [row[p] for p in preds.get(v, []) if p in row]
            return (sum(placed) / len(placed) if placed else 1e9, v[1])

        columns[c].sort(key=key)
        for i, v in enumerate(columns[c]):
            row[v] = i
    widths = {c: max(_label_width(v) for v in vs) for c, vs in columns.items()}
    x_left: dict[int, float] = {}
    x = float(MARGIN)
    for c in sorted(columns):
        x_left[c] = x
        x += widths[c] + COL_GAP
    width = max(x - COL_GAP + MARGIN, 2 * MARGIN + 120)
    rows = max((len(vs) for vs in columns.values()), default=1)
    height = rows * ROW_H + 2 * MARGIN
    center: dict[tuple[str, str], tuple[float, float, float]] = {}
    for c, vs in columns.items():
        offset = (rows - len(vs)) * ROW_H / 2
        for i, v in enumerate(vs):
            w = _label_width(v)
            cx = x_left[c] + widths[c] / 2
            cy = MARGIN + offset + i * ROW_H + ROW_H / 2
            center[v] = (cx, cy, w)

    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" height="{height:.0f}" '
        f'viewBox="0 0 {width:.0f} {height:.0f}" font-family="sans-serif" font-size="12">',
        f"<title>{escape(title)}</title>",
        '<defs><marker id="arrow" viewBox="0 0 10 10" refX="10" refY="5" '
        'markerWidth="7" markerHeight="7" orient="auto-start-reverse">'
        '<path d="M 0 0 L 10 5 L 0 10 z" fill="#444"/></marker></defs>',
    ]
    for a, b in g.edges:
        ax, ay, aw = center[a]
        bx, by, bw = center[b]
        if layer[b] == layer[a] + 1:
            x1, x2 = ax + aw / 2, bx - bw / 2
            mid = (x1 + x2) / 2
            d = f"M {x1:.1f} {ay:.1f} C {mid:.1f} {ay:.1f}, {mid:.1f} {by:.1f}, {x2:.1f} {by:.1f}"
        elif layer[b] > layer[a]:  # skips columns: pass above what stands in between
            between = range(layer[a] + 1, layer[b])
            top = min(center[v][1] for c in between for v in columns[c]) - BOX_H / 2
            y = max(top - ROUTE_GAP, ROUTE_GAP / 2)
            x1, x2 = ax + aw / 2, bx - bw / 2
            x_in, x_out = x_left[between[0]] - ROUTE_GAP, x_left[between[-1]] + widths[between[-1]]
            x_out += ROUTE_GAP
            m1, m2 = (x1 + x_in) / 2, (x_out + x2) / 2
            d = (
                f"M {x1:.1f} {ay:.1f} C {m1:.1f} {ay:.1f}, {m1:.1f} {y:.1f}, {x_in:.1f} {y:.1f} "
                f"L {x_out:.1f} {y:.1f} C {m2:.1f} {y:.1f}, {m2:.1f} {by:.1f}, {x2:.1f} {by:.1f}"
            )
        else:  # a back edge (a cycle): loop below the boxes
            x1, x2 = ax, bx
            y1, y2 = ay + BOX_H / 2, by + BOX_H / 2
            low = max(y1, y2) + ROW_H * 0.45
            d = f"M {x1:.1f} {y1:.1f} C {x1:.1f} {low:.1f}, {x2:.1f} {low:.1f}, {x2:.1f} {y2:.1f}"
        out.append(
            f'<path class="edge" data-from="{escape(a[1])}" data-to="{escape(b[1])}" d="{d}" '
            'fill="none" stroke="#444" stroke-width="1.3" marker-end="url(#arrow)"/>'
        )
    for v, (cx, cy, w) in sorted(center.items()):
        kind, name = v
        if kind == "node":
            shape = (
                f'<ellipse cx="{cx:.1f}" cy="{cy:.1f}" rx="{w / 2:.1f}" ry="{BOX_H / 2:.1f}" '
                'fill="#dbe9f6" stroke="#2b5d8a"/>'
            )
        else:
            shape = (
                f'<rect x="{cx - w / 2:.1f}" y="{cy - BOX_H / 2:.1f}" width="{w:.1f}" '
                f'height="{BOX_H}" fill="#fdf3d8" stroke="#8a6d1f"/>'
            )
        out.append(
            f'<g class="{kind}" data-name="{escape(name)}">{shape}'
            f'<text x="{cx:.1f}" y="{cy + 4:.1f}" text-anchor="middle">{escape(name)}</text></g>'
        )
    out.append("</svg>")
    return "\n".join(out)


def graph_svg(
    node: Node | None = None, *, include_hidden: bool = False, include_debug: bool = False
) -> str:
    """The live graph as SVG text (``IPython.display.SVG(graph_svg())`` shows it)."""
    return to_svg(collect(node, include_hidden=include_hidden, include_debug=include_debug))
