"""The browser editor's page: the app bar (the file actions), the tools strip (modes, target, tool,
mirror, free, stretch), the view with its status line, the brush's ring and the build's progress.

The strip wraps onto a second row in a narrow page (a notebook cell) rather than overflowing.
"""

from __future__ import annotations

from pathlib import Path

from .brush_ring import RING_ID, RING_SCRIPT, RING_STYLE, VIEW_BOX_ID
from .gestures import BRUSH, CAMERA, DRAG, HANDLE, POSE, RECTANGLE, ROI, SELECT
from .keys import KEY_SCRIPT
from .pose_hover import HOVER_SCRIPT

__all__ = ["build_page"]


def build_page(web) -> None:
    """Lay out the page of ``web`` (a :class:`~.editor_app.WebEditor`: its server, render window, state and
    actions); sets ``web.layout`` and ``web.view`` (the remote view)."""
    from trame.ui.vuetify3 import SinglePageLayout
    from trame.widgets import client, html
    from trame.widgets import vtk as vtk_widgets
    from trame.widgets import vuetify3 as v3

    name = web.name
    with SinglePageLayout(web.server) as layout:
        web.layout = layout
        layout.title.set_text(f"hybridedit: {name}")
        with layout.toolbar:
            v3.VSpacer()
            v3.VBtn("Undo", id="undo", click=(web.undo,), density="compact", title="Undo (Ctrl+Z)")
            v3.VBtn("Redo", id="redo", click=(web.redo,), density="compact", title="Redo (Ctrl+Shift+Z)")
            v3.VTextField(v_model=("save_name", ""), id="save_name", density="compact", hide_details=True,
                          variant="outlined", single_line=True, style="max-width: 220px",
                          title="The file Save writes, in the mesh's folder")
            v3.VBtn("Save", id="save", click=(web.save,), density="compact",
                    title="Write the posed mesh on the server, in the mesh's folder (atomically)")
            v3.VBtn("Save Edit", id="save_edit", click=(web.save_edit,), density="compact",
                    title="Save how the pose was made beside the mesh (hybridedit deform replays it)")
            v3.VBtn("Download", id="download", density="compact", title="The posed mesh, as PLY",
                    click=f"utils.download('{Path(name).stem}-posed.ply', trigger('download_mesh'),"
                          " 'application/octet-stream')")
        with layout.content:
            with html.Div(style="display: flex; flex-direction: column; height: 100%; width: 100%"):
                # the tools wrap onto a second row in a narrow page (a notebook cell) rather than overflow
                with html.Div(id="tools", style="display: flex; flex-wrap: wrap; gap: 4px 8px;"
                                                " align-items: center; padding: 4px 8px; flex: 0 0 auto"):
                    with v3.VBtnToggle(v_model=("mode", CAMERA), mandatory=True, density="compact", id="mode"):
                        v3.VBtn("Camera (C)", value=CAMERA, id="mode_camera")
                        v3.VBtn("Select (S)", value=SELECT, id="mode_select")
                        v3.VBtn("Drag (D)", value=DRAG, id="mode_drag")
                        v3.VBtn("Pose (P)", value=POSE, id="mode_pose")
                    with v3.VBtnToggle(v_model=("target", ROI), mandatory=True, density="compact", id="target"):
                        v3.VBtn("ROI (R)", value=ROI, id="target_roi")
                        v3.VBtn("Handle (H)", value=HANDLE, id="target_handle")
                    with v3.VBtnToggle(v_model=("tool", RECTANGLE), mandatory=True, density="compact", id="tool"):
                        v3.VBtn("Rectangle (X)", value=RECTANGLE, id="tool_rect")
                        v3.VBtn("Brush (B)", value=BRUSH, id="tool_brush")
                    v3.VBtn("Mirror X", id="mirror_x", click=(web.toggle_mirror,), density="compact",
                            active=("mirror", False), variant="tonal",
                            title="Mirror the selection and the drag across X (Shift+X)")
                    v3.VBtn("Free", id="free_around_handle", click=(web.free_around_handles,),
                            density="compact", variant="tonal",
                            title="Free the held cage points around the handle (Shift+F)")
                    v3.VBtn("Stretch (T)", id="stretch", click=(web.toggle_stretch,), density="compact",
                            active=("stretch", False), variant="tonal",
                            title="Colour the shape by its edge-length change")
                with html.Div(id=VIEW_BOX_ID, style="position: relative; flex: 1 1 auto; min-height: 0"):
                    web.view = vtk_widgets.VtkRemoteView(web.plotter.render_window, ref="view",
                                                          interactive_ratio=1, still_quality=90,
                                                          interactive_quality=70)
                    html.Div(id=RING_ID, style=RING_STYLE)
                    # the build's progress over the shape read (or an empty view), with Cancel
                    with html.Div(v_if=("building",), id="building",
                                  style="position: absolute; left: 50%; top: 40%; transform: translate(-50%, -50%);"
                                        " width: min(420px, 80%); background: rgba(255,255,255,0.9);"
                                        " padding: 12px 16px; border-radius: 6px; font: 14px sans-serif"):
                        with html.Div(v_if=("!build_failed",)):
                            html.Div("{{ build_stage }} ({{ build_percent }}%)", id="build_stage")
                            v3.VProgressLinear(model_value=("build_percent", 0), height=8, color="primary",
                                               classes="my-2")
                            v3.VBtn("Cancel", id="cancel_build", click=(web.cancel_build,), density="compact",
                                    variant="tonal")
                        with html.Div(v_if=("build_failed",)):
                            html.Div("{{ build_failed }}", id="build_failed")
                            v3.VBtn("Open Again", id="open_again", click=(web.open_again,), density="compact",
                                    variant="tonal", classes="mt-2")
                    html.Div("{{ status }}", id="status",
                             style="position: absolute; left: 8px; bottom: 4px; font: 13px sans-serif;"
                                   " background: rgba(255,255,255,0.7); padding: 2px 6px")
        client.Script(KEY_SCRIPT)
        client.Script(RING_SCRIPT)
        client.Script(HOVER_SCRIPT)
