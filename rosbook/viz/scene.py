"""MeshCat views of a URDF robot: the book's stand-in for RViz, live or recorded.

A :class:`RobotView` draws every ``<visual>`` of a :class:`rosbook.robots.urdf.Robot` (box,
cylinder, sphere, mesh; with its material colour and origin) at the pose forward
kinematics gives it, shows each link's frame as a triad, moves the robot when joint
positions or the base pose change, and records animations.

It draws into a MeshCat ``Visualizer``. Without one it draws into a :class:`Recorder`:
MeshCat's own command objects are kept instead of being sent to a server, so no
process is started. :meth:`RobotView.scene` turns what was recorded into a
:class:`Scene`, which a notebook cell displays as an interactive 3D view. In the built
book the viewer's JavaScript is loaded once from ``_static`` (see
``rosbook.book.sphinx_meshcat``), so a page carries only its scenes' commands.
"""

from __future__ import annotations

import atexit
import base64
import html
import io
import json
import math
import os
import signal
import subprocess
import sys
import uuid
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import meshcat
import meshcat.geometry as g
import numpy as np
import trimesh
import umsgpack
from meshcat.animation import Animation
from meshcat.visualizer import ViewerWindow

from rosbook.robots.urdf import Robot

#: The MeshCat viewer (three.js and MeshCat's JavaScript, about 0.85 MB, minified).
VIEWER_JS = Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"
#: Where the book serves the viewer from, relative to its ``_static`` folder.
VIEWER_STATIC_NAME = "meshcat/main.min.js"
#: Set to "shared" where pages load the viewer script themselves (the book build).
VIEWER_MODE_VARIABLE = "ROSBOOK_MESHCAT_VIEWER"
#: The class of the HTML element a scene is drawn in (the Sphinx extension looks for it).
SCENE_CLASS = "rosbook-meshcat-scene"
#: Where MeshCat's default camera looks from (its ``(3, 1, 0)`` in the viewer's frame).
DEFAULT_VIEW_DIRECTION = (3.0, 0.0, 1.0)

#: three.js draws a cylinder along its y axis, URDF along z: turn y onto z (+90 deg about x).
CYLINDER_Y_TO_Z = np.array(
    [[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, -1.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]]
)
DEFAULT_RGBA = (0.75, 0.75, 0.75, 1.0)


class Recorder:
    """A stand-in for MeshCat's server window: keeps each command, sends nothing."""

    def __init__(self) -> None:
        self.commands: list[dict[str, Any]] = []

    def send(self, command: Any) -> None:
        self.commands.append(command.lower())


def recording_visualizer() -> meshcat.Visualizer:
    """A MeshCat ``Visualizer`` that records into a :class:`Recorder` (no server)."""
    return meshcat.Visualizer(window=Recorder())


# Runs MeshCat's server after asking Linux to SIGTERM it when its parent dies.
_SERVER = (
    "import ctypes, runpy, signal, sys\n"
    "if sys.platform == 'linux':\n"
    "    ctypes.CDLL(None).prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG\n"
    "sys.argv = ['meshcat-server']\n"
    "runpy.run_module('meshcat.servers.zmqserver', run_name='__main__')\n"
)


def start_server() -> tuple[subprocess.Popen[bytes], str, str]:
    """Start MeshCat's server on localhost; return the process, its zmq and web URLs.

    Like ``meshcat.servers.zmqserver.start_zmq_server_as_subprocess``, but the server
    is also ended when the process that started it dies, even by SIGKILL (a killed
    Jupyter kernel): otherwise it would keep its ports until someone kills it.
    """
    proc = subprocess.Popen(
        [sys.executable, "-u", "-c", _SERVER],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        start_new_session=True,  # a notebook's interrupt (SIGINT) must not stop it
    )
    assert proc.stdout is not None
    line = ""
    while not line.startswith("zmq_url="):
        line = proc.stdout.readline().decode().strip()
        if not line and proc.poll() is not None:
            raise RuntimeError(f"the MeshCat server exited with code {proc.returncode}")
    zmq_url = line.split("=", 1)[1]
    web_url = proc.stdout.readline().decode().strip().split("=", 1)[1]
    atexit.register(_stop, proc)
    return proc, zmq_url, web_url


# The live view's page: MeshCat's viewer, loaded through the Jupyter server's proxy
# (jupyter-server-proxy: BASE/proxy/PORT/ reaches 127.0.0.1:PORT on the server's host,
# web sockets included), so the browser needs no port of its own to the server: it works
# on a course server as on a laptop. BASE is the Jupyter server's base URL, which
# JupyterLab and Notebook 7 publish in the page as "jupyter-config-data".
_LIVE_PAGE = """<!DOCTYPE html>
<html><head><meta charset="utf-8">
<style>body {{ margin: 0 }} #pane {{ width: 100vw; height: 100vh; overflow: hidden }}</style>
</head><body><div id="pane"></div><script>
(function () {{
  var base = "/", page = window.location;
  try {{
    var config = window.parent.document.getElementById("jupyter-config-data");
    if (config) base = JSON.parse(config.textContent).baseUrl || "/";
    page = window.parent.location;
  }} catch (e) {{}}
  var root = base.replace(/\\/?$/, "/") + "proxy/{port}/";
  var script = document.createElement("script");
  script.src = root + "static/main.min.js";
  script.onload = function () {{
    var viewer = new MeshCat.Viewer(document.getElementById("pane"));
    viewer.connect((page.protocol === "https:" ? "wss://" : "ws://") + page.host + root);
  }};
  document.body.appendChild(script);
}})();
</script></body></html>"""


class LiveVisualizer(meshcat.Visualizer):
    """A MeshCat ``Visualizer`` whose view is shown through the Jupyter server.

    ``jupyter_cell()`` (or the visualizer as a cell's last value) shows the live view:
    its page and web socket go through the Jupyter server's ``proxy/PORT/`` route, so
    only the Jupyter server's own address must be reachable from the browser.
    """

    @property
    def port(self) -> int:
        """The MeshCat server's web port, on the Jupyter server's machine."""
        return int(self.window.web_url.split(":")[-1].split("/")[0])

    def proxy_path(self) -> str:
        """The view's path under the Jupyter server's base URL."""
        return f"proxy/{self.port}/static/"

    def jupyter_cell(self, height: int = 400) -> Any:
        from IPython.display import HTML

        return HTML(self._repr_html_(height))

    def _repr_html_(self, height: int = 400) -> str:
        page = _LIVE_PAGE.format(port=self.port)
        return (
            f'<div style="height: {height}px; width: 100%; overflow: hidden; resize: both">'
            f'<iframe title="Live 3D view (MeshCat)" srcdoc="{html.escape(page, quote=True)}" '
            'style="width: 100%; height: 100%; border: none"></iframe></div>'
        )


def live_visualizer() -> LiveVisualizer:
    """A MeshCat ``Visualizer`` with its server beside the kernel (for JupyterLab).

    Its view reaches the server through the Jupyter server (see
    :class:`LiveVisualizer`). Call :func:`close_live` when done. The server also stops
    when this Python process exits or is killed.
    """
    proc, zmq_url, _ = start_server()
    window = ViewerWindow(zmq_url=zmq_url, start_server=False, server_args=[])
    window.server_proc = proc
    return LiveVisualizer(window=window)


def close_live(vis: meshcat.Visualizer) -> None:
    """Stop the MeshCat server process that ``vis`` started."""
    proc = getattr(vis.window, "server_proc", None)
    if proc is not None:
        _stop(proc)


def _stop(proc: subprocess.Popen[bytes]) -> None:
    """End a server process and its process group, and reap it."""
    if proc.poll() is None:
        try:
            os.killpg(proc.pid, signal.SIGTERM)
            proc.wait(timeout=5)
        except ProcessLookupError:
            pass
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait(timeout=5)
    if proc.stdout is not None:
        proc.stdout.close()


def rgb_hex(rgba: Sequence[float]) -> int:
    """0xRRGGBB from an URDF ``rgba`` (components 0..1)."""
    r, g_, b = (min(255, max(0, round(255 * c))) for c in rgba[:3])
    return (r << 16) | (g_ << 8) | b


def planar_pose(x: float, y: float, yaw: float, z: float = 0.0) -> np.ndarray:
    """The 4x4 pose of a robot base at (x, y, z), heading ``yaw`` (rad) about z."""
    pose = np.eye(4)
    c, s = math.cos(yaw), math.sin(yaw)
    pose[:2, :2] = [[c, -s], [s, c]]
    pose[:3, 3] = x, y, z
    return pose


def visual_rgba(robot: Robot, visual: Any) -> tuple[float, ...]:
    """A visual's colour: its own ``<material><color>``, else the robot's material of
    that name (URDF lets a link refer to a material defined once at the top), else grey.
    """
    material = visual.material
    if material is None:
        return DEFAULT_RGBA
    if material.color is not None:
        return tuple(float(v) for v in material.color.rgba)
    named = robot.materials.get(material.name)
    if named is not None and named.color is not None:
        return tuple(float(v) for v in named.color.rgba)
    return DEFAULT_RGBA


def _key(command: dict[str, Any]) -> tuple[str, ...]:
    """What a command sets: a later command with the same key replaces it."""
    kind = command["type"]
    if kind == "set_property":
        return (kind, command["path"], command["property"])
    if kind == "set_animation":
        return (kind,)
    return (kind, command.get("path", ""))


def compact(commands: Iterable[dict[str, Any]]) -> list[dict[str, Any]]:
    """The commands that still matter for the final scene, in their order.

    A set_object, set_transform or set_property is dropped when a later one sets the
    same thing, and everything below a path is dropped when that path is deleted later.
    The viewer ends in the same state; a recorded scene gets no bigger when the robot
    is moved many times before it is shown.
    """
    kept: dict[tuple[str, ...], dict[str, Any]] = {}
    for command in commands:
        if command["type"] == "delete":
            path = command["path"]
            for key in [k for k, c in kept.items() if _below(c.get("path", ""), path)]:
                del kept[key]
        key = _key(command)
        kept.pop(key, None)  # re-inserted last: keeps the order of the final commands
        kept[key] = command
    return list(kept.values())


def _below(path: str, root: str) -> bool:
    return path == root or path.startswith(root.rstrip("/") + "/")


Bounds = tuple[np.ndarray, np.ndarray]


def union(a: Bounds | None, b: Bounds | None) -> Bounds | None:
    """The box holding boxes ``a`` and ``b`` (``(lowest, highest)`` corners; None: empty)."""
    if a is None or b is None:
        return a if b is None else b
    return np.minimum(a[0], b[0]), np.maximum(a[1], b[1])


def points_bounds(points: np.ndarray) -> Bounds | None:
    """The box around an ``(n, 3)`` array of points (None when there are none)."""
    if len(points) == 0:
        return None
    return points.min(axis=0), points.max(axis=0)


def framing(
    bounds: Bounds | None, direction: Sequence[float] | None = None
) -> dict[str, list[float]] | None:
    """How the viewer frames a scene: look at the box's centre, from ``direction``.

    In world (URDF) coordinates: ``target`` the centre, ``radius`` the half diagonal (the
    viewer moves the camera back until that sphere fits its box, at any aspect ratio),
    ``direction`` where the camera looks from (only its direction counts).
    """
    if bounds is None:
        return None
    lo, hi = bounds
    look = np.asarray(direction if direction is not None else DEFAULT_VIEW_DIRECTION, float)
    if not np.linalg.norm(look) > 0:
        raise ValueError(f"camera direction {tuple(look)} has no length")
    return {
        "target": [round(float(v), 4) for v in (lo + hi) / 2],
        "radius": math.ceil(max(float(np.linalg.norm(hi - lo)) / 2, 0.05) * 1e4) / 1e4,
        "direction": [round(float(v), 4) for v in look / np.linalg.norm(look)],
    }


class Scene:
    """Recorded MeshCat commands, shown as an interactive 3D view by a notebook.

    In the book (``ROSBOOK_MESHCAT_VIEWER=shared``, set by ``rosbook.book.sphinx_meshcat``),
    ``_repr_html_`` gives a ``<div>`` and a script that replays the commands into a
    ``MeshCat.Viewer`` whose JavaScript the page loads once from ``_static``. Anywhere
    else (JupyterLab) there is no such file, so the output is a self-contained
    ``<iframe>`` that inlines the viewer (about 0.85 MB per output).

    ``frame`` (from :func:`framing`) aims the camera at what matters and fits it in the
    view box at any size; ``description`` is what the scene shows in words (the alt
    text of its still picture; by default made from the robots and objects it holds).
    """

    def __init__(
        self,
        commands: Iterable[dict[str, Any]],
        height: int = 360,
        frame: Mapping[str, Any] | None = None,
        description: str | None = None,
    ) -> None:
        self.commands = compact(commands)
        self.height = height
        self.frame = dict(frame) if frame is not None else None
        self.description = description or self.describe()

    def describe(self) -> str:
        """A sentence saying what the scene holds, made from its scene tree."""
        robots: dict[str, set[str]] = {}
        others: set[str] = set()
        for c in self.commands:
            if c["type"] != "set_object" or not c["path"].startswith("/meshcat/"):
                continue
            parts = c["path"].split("/")[2:]
            if len(parts) >= 3 and (parts[2].startswith("visual_") or parts[2] == "frame"):
                robots.setdefault(parts[0], set()).add(parts[1])
            else:
                others.add(parts[0])
        said = [
            f"the robot {name} ({len(links)} links: {', '.join(sorted(links))})"
            for name, links in robots.items()
        ]
        said += [f"the {name}" for name in sorted(others - set(robots))]
        moving = any(c["type"] == "set_animation" for c in self.commands)
        what = " and ".join(said) if said else "an empty scene"
        return f"{'Animated 3D' if moving else '3D'} view of {what}, on MeshCat's floor grid."

    @property
    def packed(self) -> list[bytes]:
        """Each command as MeshCat's viewer receives it (msgpack)."""
        return [umsgpack.packb(c) for c in self.commands]

    @property
    def paths(self) -> list[str]:
        """Every scene-tree path a command touches, in order, without repeats."""
        seen: dict[str, None] = {}
        for c in self.commands:
            if "path" in c:
                seen[c["path"]] = None
            for animation in c.get("animations", []):
                seen[animation["path"]] = None
        return list(seen)

    def nbytes(self) -> int:
        return sum(len(p) for p in self.packed)

    def payload(self) -> str:
        """The commands for the page: a JSON list of base64 msgpack strings.

        Base64 has no ``<`` or ``&``, so the list can sit in a ``<script>`` unescaped.
        """
        return json.dumps([base64.b64encode(p).decode() for p in self.packed])

    def _repr_html_(self) -> str:
        if os.environ.get(VIEWER_MODE_VARIABLE) == "shared":
            return self.shared_html()
        return self.inline_html()

    def inline_html(self) -> str:
        """An ``<iframe>`` holding the viewer and the scene: works with no other file."""
        page = (
            "<!DOCTYPE html><html><head><meta charset='utf-8'>"
            f"<script>{VIEWER_JS.read_text()}</script>"
            "<style>body { margin: 0; }</style></head><body>"
            f"{self.shared_html()}</body></html>"
        )
        return (
            f'<iframe title="{html.escape(self.description, quote=True)}" '
            f'srcdoc="{html.escape(page, quote=True)}" '
            f'style="width: 100%; height: {self.height + 4}px; border: none"></iframe>'
        )

    def shared_html(self) -> str:
        """The scene's pane and commands; the page must load the viewer script itself."""
        element = f"meshcat-{uuid.uuid4().hex[:12]}"
        frame = html.escape(json.dumps(self.frame), quote=True)
        return (
            # MeshCat puts its control panel in the pane's parent, at its top right:
            # the outer div is that (positioned) parent. The pane (the picture) is the
            # image with the scene's description; the panel beside it holds controls,
            # which an image may not.
            f'<div class="{SCENE_CLASS}" id="{element}" data-frame="{frame}" '
            f'style="height: {self.height}px; width: 100%; position: relative; '
            f'overflow: hidden">'
            f'<div id="{element}-pane" role="img" '
            f'aria-label="{html.escape(self.description, quote=True)}" '
            f'style="width: 100%; height: 100%"></div></div>\n'
            f'<script type="application/json" id="{element}-commands">'
            f"{self.payload()}</script>\n"
            f"<script>{_PLAYER_JS % {'id': element}}</script>\n"
        )

    def standalone_html(self, viewer_src: str) -> str:
        """A whole HTML page with this scene, loading the viewer from ``viewer_src``."""
        return (
            "<!DOCTYPE html><html><head><meta charset='utf-8'><title>MeshCat scene</title>"
            f"<script src='{viewer_src}'></script></head><body>"
            f"{self.shared_html()}</body></html>"
        )

    def __repr__(self) -> str:
        return f"<Scene: {len(self.commands)} MeshCat commands, {self.nbytes()} bytes>"


# Replays a scene's commands into a viewer once the shared viewer script has loaded.
# MeshCat sizes its canvas to the window's height; here it is sized to the scene's box
# (and again whenever the box changes size), the camera is aimed at the scene's
# ``data-frame`` and moved back until it fits, and the control panel starts closed (and
# is left out of a box narrower than a phone's screen, where it would cover the view).
# ``data-frames`` counts the frames drawn and ``data-first-frame-ms`` says when the first
# was, since the page's navigation started (the tests and the benchmark read them).
# A playing animation is paused while its box is off the screen and plays on from where
# it was when the box is back (``data-on-screen`` says which): a page of looping drives
# drew every scene 60 times a second wherever the reader was, about two cores' worth
# in software WebGL. A pause by the reader (or a script) is left alone.
_PLAYER_JS = """
(function () {
  var id = "%(id)s";
  function play() {
    var box = document.getElementById(id);
    var pane = document.getElementById(id + "-pane");
    if (typeof MeshCat === "undefined") {
      pane.textContent = pane.getAttribute("aria-label")
        + " (The 3D view needs the MeshCat viewer script.)";
      return;
    }
    var viewer = new MeshCat.Viewer(pane);
    var commands = JSON.parse(document.getElementById(id + "-commands").textContent);
    commands.forEach(function (b64) {
      var bytes = Uint8Array.from(atob(b64), function (c) { return c.charCodeAt(0); });
      viewer.handle_command_bytearray(bytes);
    });
    var frame = JSON.parse(box.dataset.frame || "null");
    var render = viewer.render.bind(viewer);
    viewer.render = function () {
      render();
      if (!box.dataset.frames) { box.dataset.firstFrameMs = performance.now().toFixed(0); }
      box.dataset.frames = (parseInt(box.dataset.frames || "0", 10) + 1).toString();
    };
    function fit(direction) {
      if (!frame) { return; }
      var t = frame.target, camera = viewer.camera, target = viewer.controls.target;
      target.set(t[0], t[2], -t[1]);  /* world (x, y, z) in the viewer's frame */
      var half = camera.fov * Math.PI / 360;
      half = Math.min(half, Math.atan(Math.tan(half) * camera.aspect));
      var distance = 1.1 * frame.radius / Math.sin(half);
      var d = direction, n = Math.hypot(d[0], d[1], d[2]);
      camera.position.set(t[0] + distance * d[0] / n, t[2] + distance * d[1] / n,
                          -t[1] + distance * d[2] / n);
      viewer.controls.update();
    }
    var size = viewer.set_3d_pane_size.bind(viewer);
    var fitted = false;
    viewer.set_3d_pane_size = function () {
      var width = pane.clientWidth, height = pane.clientHeight;
      if (!width || !height) { return; }
      size(width, height);
      if (frame) {
        var p = viewer.camera.position, t = viewer.controls.target;
        var d = [frame.direction[0], frame.direction[2], -frame.direction[1]];
        if (fitted) { d = [p.x - t.x, p.y - t.y, p.z - t.z]; }
        fit(d);
        fitted = true;
      }
      viewer.gui.domElement.style.display = width < 500 ? "none" : "";
      viewer.set_dirty();
    };
    viewer.gui.close();
    label(viewer.gui.domElement);
    viewer.set_3d_pane_size();
    if (typeof ResizeObserver !== "undefined") {
      new ResizeObserver(function () { viewer.set_3d_pane_size(); }).observe(pane);
    }
    if (typeof IntersectionObserver !== "undefined") {
      var animator = viewer.animator, pause = animator.pause, resume = animator.play;
      var held = false;  /* paused here because the box left the screen */
      animator.pause = function () { held = false; return pause.apply(animator, arguments); };
      animator.play = function () { held = false; return resume.apply(animator, arguments); };
      new IntersectionObserver(function (entries) {
        var shown = entries[entries.length - 1].isIntersecting;
        box.dataset.onScreen = shown ? "1" : "0";
        if (!shown && animator.playing) { pause.call(animator); held = true; }
        else if (shown && held) { held = false; resume.call(animator); }
      }).observe(box);
    }
    pane.meshcatViewer = viewer;
    box.classList.add("rosbook-scene-live");
  }
  /* The control panel, for a keyboard and a screen reader: each control named by its
     folders and property ("Scene / Lights: castShadow"; a folder's visibility box
     "show Scene / Lights"), the open/close bar a button, a closed panel's controls out
     of the tab order. Again whenever the panel changes (MeshCat adds folders). */
  function label(panel) {
    function folders(control) {
      var names = [];
      for (var f = control.closest("li.folder"); f; f = f.parentElement.closest("li.folder")) {
        var title = f.querySelector(":scope > .dg > ul > li.title");
        if (title) { names.unshift(title.textContent); }
      }
      return names.join(" / ");
    }
    function name() {
      panel.querySelectorAll("input, select").forEach(function (control) {
        var row = control.closest("li.cr");
        var property = row && row.querySelector(".property-name");
        var where = folders(control);
        control.setAttribute("aria-label", property
          ? (where ? where + ": " : "") + property.textContent : "show " + where);
      });
      var bar = panel.querySelector(":scope > .close-button");
      var list = panel.querySelector(":scope > ul");
      if (bar && list) {
        var open = !list.classList.contains("closed");
        bar.setAttribute("role", "button");
        bar.setAttribute("tabindex", "0");
        bar.setAttribute("aria-expanded", open ? "true" : "false");
        list.inert = !open;
      }
    }
    var bar = panel.querySelector(":scope > .close-button");
    if (bar) {
      bar.addEventListener("keydown", function (event) {
        if (event.key === "Enter" || event.key === " ") { event.preventDefault(); bar.click(); }
      });
    }
    name();
    new MutationObserver(name).observe(panel, {
      childList: true, subtree: true, attributes: true, attributeFilter: ["class"]
    });
  }
  if (document.readyState === "complete") { play(); }
  else { window.addEventListener("load", play); }
})();
"""


class RobotView:
    """A robot drawn in MeshCat from its URDF, moved by joint positions and base pose.

    ``vis`` is a MeshCat ``Visualizer`` (a live one, or by default one that records).
    The scene tree is ``/meshcat/<prefix>/<link>/visual_<i>`` and ``.../frame``; each
    link node carries its pose from forward kinematics, and ``/meshcat/<prefix>`` the
    base pose on the floor, so a 2D simulator can drive the twin with
    :meth:`set_base_pose` and :meth:`set_joints`.

    ``standing=True`` lifts the root link so that the robot's lowest point (at zero
    joint positions) touches the floor, z = 0, where MeshCat draws its grid; with
    ``False`` the root link's origin is on the floor.
    """

    def __init__(
        self,
        robot: Robot,
        vis: meshcat.Visualizer | None = None,
        prefix: str | None = None,
        frames: bool = False,
        frame_scale: float = 0.1,
        camera: Sequence[float] | None = None,
        standing: bool = True,
    ) -> None:
        self.robot = robot
        self.vis = vis if vis is not None else recording_visualizer()
        self.prefix = prefix or robot.name
        self.positions: dict[str, float] = {}
        self.height = -lowest_point(robot) if standing else 0.0
        self.base = planar_pose(0.0, 0.0, 0.0, self.height)
        self.frame_scale = frame_scale
        self.camera = camera
        #: The box the robot has been in so far (world coordinates): the scene's framing.
        self.bounds: Bounds | None = None
        self._corners = visual_corners(robot)
        self._draw(camera)
        self.show_frames(frames)
        self.set_joints({})
        self.set_base_pose(0.0, 0.0, 0.0)

    @property
    def root(self) -> meshcat.Visualizer:
        return self.vis[self.prefix]

    def _draw(self, camera: Sequence[float] | None) -> None:
        self.root.delete()
        for link in self.robot.model.robot.links:
            for i, visual in enumerate(link.visuals):
                drawn = self._geometry(visual)
                if drawn is None:
                    continue
                geometry, correction = drawn
                rgba = visual_rgba(self.robot, visual)
                material = g.MeshLambertMaterial(
                    color=rgb_hex(rgba), opacity=float(rgba[3]), transparent=rgba[3] < 1
                )
                node = self.root[link.name][f"visual_{i}"]
                node.set_object(geometry, material)
                origin = np.eye(4) if visual.origin is None else np.asarray(visual.origin)
                node.set_transform(origin @ correction)
            self.root[link.name]["frame"].set_object(g.triad(self.frame_scale))
        if camera is not None:
            self.vis["/Cameras/default/rotated/<object>"].set_property(
                "position", [float(camera[0]), float(camera[2]), float(-camera[1])]
            )

    def _geometry(self, visual: Any) -> tuple[g.Geometry, np.ndarray] | None:
        """MeshCat geometry for a URDF visual, and the transform that matches the axes."""
        shape = visual.geometry
        if shape.box is not None:
            return g.Box([float(v) for v in shape.box.size]), np.eye(4)
        if shape.cylinder is not None:
            c = shape.cylinder
            return g.Cylinder(float(c.length), float(c.radius)), CYLINDER_Y_TO_Z
        if shape.sphere is not None:
            return g.Sphere(float(shape.sphere.radius)), np.eye(4)
        if shape.mesh is not None:
            mesh = self.robot.mesh(shape.mesh.filename)
            vertices = np.asarray(mesh.vertices, dtype=float)
            if shape.mesh.scale is not None:
                vertices = vertices * np.asarray(shape.mesh.scale, dtype=float)
            return g.TriangularMeshGeometry(vertices, np.asarray(mesh.faces)), np.eye(4)
        return None

    def show_frames(self, visible: bool = True) -> None:
        """Show or hide every link's frame triad (x red, y green, z blue)."""
        for link in self.robot.links:
            self.root[link]["frame"].set_property("visible", bool(visible))

    def set_joints(self, positions: Mapping[str, float]) -> None:
        """Move the joints named in ``positions`` (others keep their position)."""
        self.positions.update({k: float(v) for k, v in positions.items()})
        for link, pose in self.robot.poses(self.positions).items():
            self.root[link].set_transform(pose)
        self._extend(self.positions, self.base)

    def _extend(self, positions: Mapping[str, float], base: np.ndarray) -> None:
        """Grow :attr:`bounds` by the robot at ``positions`` placed at ``base``."""
        poses = self.robot.poses(positions)
        points = [
            (base @ poses[link] @ np.c_[corners, np.ones(len(corners))].T).T[:, :3]
            for link, corners in self._corners.items()
        ]
        if points:
            self.bounds = union(self.bounds, points_bounds(np.concatenate(points)))

    def include_pose(self, x: float, y: float, yaw: float) -> None:
        """Frame the view around the robot at (x, y, yaw) too (a pose it drives through)."""
        self.include_base(planar_pose(x, y, yaw, self.height))

    def include(self, bounds: Bounds | None) -> None:
        """Frame the view around ``bounds`` too (e.g. the world the robot drives in)."""
        self.bounds = union(self.bounds, bounds)

    def set_base_pose(self, x: float, y: float, yaw: float) -> None:
        """Place the robot at (x, y) on the floor, heading ``yaw`` (rad).

        (x, y, yaw) is the root link's pose in the world, as a 2D simulator or odometry
        gives it (the ``odom`` -> ``base_link`` transform); the height is the view's.
        """
        self.place(planar_pose(x, y, yaw))

    def placed(self, pose: np.ndarray) -> np.ndarray:
        """Where the root link is drawn for ``pose`` (4x4, in the world): lifted by the
        view's height, so that a pose on the floor (z = 0) stands the robot on it."""
        lifted = np.array(pose, dtype=float)
        lifted[2, 3] += self.height
        return lifted

    def place(self, pose: np.ndarray) -> None:
        """Put the root link at ``pose`` (a 4x4 transform in the world, e.g. a tf2 lookup
        of ``base_link`` in ``odom``), lifted by the view's height (:meth:`placed`)."""
        self.base = self.placed(pose)
        self.root.set_transform(self.base)
        self._extend(self.positions, self.base)

    def include_base(self, base: np.ndarray) -> None:
        """Frame the view around the robot with its root link at ``base`` too (4x4, in the
        scene: e.g. :meth:`placed`'s answer for a pose it goes through)."""
        self._extend(self.positions, base)

    def animate(
        self,
        frames: Iterable[Mapping[str, float] | tuple[Mapping[str, float], Sequence[float]]],
        fps: int = 30,
        repetitions: int = 1,
    ) -> Animation:
        """Record and play an animation, one frame per item of ``frames``.

        An item is a joint-position dict, or ``(positions, (x, y, yaw))`` to move the
        base too. The viewer interpolates between frames and offers play controls.
        """
        animation = Animation(default_framerate=fps)
        positions = dict(self.positions)
        for k, item in enumerate(frames):
            if isinstance(item, tuple):
                joints, base = item
                base_pose: np.ndarray | None = planar_pose(*base, self.height)
            else:
                joints, base_pose = item, None
            positions.update(joints)
            self._extend(positions, base_pose if base_pose is not None else self.base)
            with animation.at_frame(self.vis, k) as frame:
                for link, pose in self.robot.poses(positions).items():
                    frame[self.prefix][link].set_transform(pose)
                if base_pose is not None:
                    frame[self.prefix].set_transform(base_pose)
        self.vis.set_animation(animation, play=True, repetitions=repetitions)
        return animation

    def scene(self, height: int = 360) -> Scene:
        """Everything recorded so far, as a :class:`Scene` (needs a recording view)."""
        window = self.vis.window
        if not isinstance(window, Recorder):
            raise TypeError("scene() needs a recording view: RobotView(robot) without vis")
        return Scene(window.commands, height=height, frame=framing(self.bounds, self.camera))


def final_transforms(commands: Iterable[Mapping[str, Any]]) -> dict[str, np.ndarray]:
    """Each scene-tree path's own (parent-relative) 4x4 transform at the end of a recorded
    scene: its last ``set_transform``, overridden by the last keys of its animation's
    position and quaternion tracks (``Scene.commands``, or those decoded from a page)."""
    static: dict[str, np.ndarray] = {}
    for command in commands:
        if command["type"] == "set_transform":
            static[command["path"]] = np.array(command["matrix"], dtype=float).reshape(4, 4).T
    tracks = final_keys(commands)
    for path in set(static) | set(tracks):
        pose = static.get(path, np.eye(4)).copy()
        animated = tracks.get(path, {})
        if "quaternion" in animated:
            pose[:3, :3] = rotation_of(animated["quaternion"])
        if "position" in animated:
            pose[:3, 3] = animated["position"]
        static[path] = pose
    return static


def final_keys(commands: Iterable[Mapping[str, Any]]) -> dict[str, dict[str, Any]]:
    """The last key of every animation track, by path and property (``position``,
    ``quaternion``, ``visible``, ...); a later ``set_animation`` replaces an earlier one."""
    tracks: dict[str, dict[str, Any]] = {}
    for command in commands:
        if command["type"] == "set_animation":
            tracks = {}
            for animated in command["animations"]:
                for track in animated["clip"]["tracks"]:
                    last = track["keys"][-1]["value"]
                    tracks.setdefault(animated["path"], {})[track["name"].lstrip(".")] = last
    return tracks


def final_properties(commands: Iterable[Mapping[str, Any]], name: str) -> dict[str, Any]:
    """Each path's property ``name`` (e.g. ``visible``) at the end of a recorded scene:
    its last ``set_property``, overridden by the last key of its animation track."""
    values: dict[str, Any] = {}
    for command in commands:
        if command["type"] == "set_property" and command["property"] == name:
            values[command["path"]] = command["value"]
    for path, keys in final_keys(commands).items():
        if name in keys:
            values[path] = keys[name]
    return values


def rotation_of(quaternion: Sequence[float]) -> np.ndarray:
    """The 3x3 rotation of a three.js (x, y, z, w) quaternion."""
    x, y, z, w = quaternion
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )


def show(robot: Robot, positions: Mapping[str, float] | None = None, **kwargs: Any) -> Scene:
    """A recorded scene of ``robot`` at ``positions``, frames shown: one call per picture."""
    height = kwargs.pop("height", 360)
    kwargs.setdefault("frames", True)
    view = RobotView(robot, **kwargs)
    view.set_joints(positions or {})
    return view.scene(height=height)


# --- a still picture, for places without a 3D viewer (lab feedback pages) -------------


def _visual_mesh(robot: Robot, visual: Any) -> trimesh.Trimesh | None:
    """A visual's shape as triangles in its link's frame (URDF axes: cylinders along z)."""
    shape = visual.geometry
    if shape.box is not None:
        mesh = trimesh.creation.box(extents=[float(v) for v in shape.box.size])
    elif shape.cylinder is not None:
        c = shape.cylinder
        mesh = trimesh.creation.cylinder(float(c.radius), float(c.length), sections=24)
    elif shape.sphere is not None:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=float(shape.sphere.radius))
    elif shape.mesh is not None:
        mesh = robot.mesh(shape.mesh.filename)
        if shape.mesh.scale is not None:
            mesh.apply_scale(np.asarray(shape.mesh.scale, dtype=float))
    else:
        return None
    if visual.origin is not None:
        mesh.apply_transform(np.asarray(visual.origin, dtype=float))
    return mesh


def visual_corners(robot: Robot) -> dict[str, np.ndarray]:
    """The corners of each link's visuals' boxes, in the link's frame (for framing)."""
    corners: dict[str, np.ndarray] = {}
    for link in robot.model.robot.links:
        boxes = [m.bounds for v in link.visuals if (m := _visual_mesh(robot, v)) is not None]
        if boxes:
            corners[link.name] = np.array(
                [
                    [b[i][0], b[j][1], b[k][2]]
                    for b in boxes
                    for i in (0, 1)
                    for j in (0, 1)
                    for k in (0, 1)
                ]
            )
    return corners


def lowest_point(robot: Robot, positions: Mapping[str, float] | None = None) -> float:
    """The lowest z of all the robot's visuals, in the root frame (0 if none)."""
    poses = robot.poses(positions or {})
    lowest = math.inf
    for link in robot.model.robot.links:
        for visual in link.visuals:
            mesh = _visual_mesh(robot, visual)
            if mesh is not None:
                mesh.apply_transform(poses[link.name])
                lowest = min(lowest, float(mesh.vertices[:, 2].min()))
    return 0.0 if lowest == math.inf else lowest


def sketch(
    robot: Robot, positions: Mapping[str, float] | None = None, title: str | None = None
) -> bytes:
    """A small PNG of ``robot``: seen from above (x right, y up) and from its right side.

    Flat-coloured triangles drawn far to near; enough to see a part in the wrong place
    or turned the wrong way, at a few tens of kilobytes (for lab feedback pages).
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.collections import PolyCollection
    from matplotlib.figure import Figure

    triangles, colours = [], []
    poses = robot.poses(positions or {})
    for link in robot.model.robot.links:
        for visual in link.visuals:
            mesh = _visual_mesh(robot, visual)
            if mesh is None:
                continue
            mesh.apply_transform(poses[link.name])
            triangles.append(np.asarray(mesh.triangles))
            colours.extend([visual_rgba(robot, visual)] * len(mesh.faces))
    figure = Figure(figsize=(6.4, 3.0), dpi=72)
    FigureCanvasAgg(figure)
    if not triangles:
        figure.text(0.5, 0.5, "no <visual> to draw", ha="center")
    else:
        tris = np.concatenate(triangles)
        rgba = np.array(colours)
        for k, (name, (u, v), depth) in enumerate(
            [("from above", (0, 1), 2), ("from the right side (-y)", (0, 2), 1)]
        ):
            axes = figure.add_subplot(1, 2, k + 1)
            order = np.argsort(tris[:, :, depth].mean(axis=1))
            if depth == 1:
                order = order[::-1]  # seen from -y: large y is far, drawn first
            axes.add_collection(
                PolyCollection(
                    tris[order][:, :, [u, v]],
                    facecolors=rgba[order],
                    edgecolors=(0, 0, 0, 0.25),
                    linewidths=0.2,
                )
            )
            axes.autoscale_view()
            axes.set_aspect("equal")
            axes.set_title(name, fontsize=9)
            axes.set_xlabel("x (m)", fontsize=8)
            axes.set_ylabel("y (m)" if v == 1 else "z (m)", fontsize=8)
            axes.tick_params(labelsize=7)
            axes.grid(alpha=0.3)
            axes.set_facecolor("#dde3ea")
    if title:
        figure.suptitle(title, fontsize=10)
    figure.tight_layout()
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png")
    return buffer.getvalue()
