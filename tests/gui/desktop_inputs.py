"""Screenshots of the dock's import / export, lens, fit settings and chips in the REAL QGIS desktop (Aletsch).

Not a pytest module: run with
``xvfb-run -a -s "-screen 0 1600x1000x24" qgis --nologo --noversioncheck --code tests/gui/desktop_inputs.py``
(MONOPLOT_REPO = the checkout, the venv's site-packages on PYTHONPATH, as tests/gui/run_desktop_aletsch.sh does).
Writes test-artifacts/inputs_*.png and inputs_session.json.
"""

import os
import sys

import qgis.utils
from qgis.core import QgsCoordinateReferenceSystem, QgsProject, QgsRasterLayer
from qgis.PyQt.QtCore import Qt, QTimer

sys.path.insert(0, os.path.join(os.environ["MONOPLOT_REPO"], "tests", "gui"))
from desktop_kit import DATA, DesktopSession  # noqa: E402

iface = qgis.utils.iface
session = DesktopSession("inputs")
report, shot, finish, guarded = session.report, session.shot, session.finish, session.guarded
state = {}


@guarded
def step1():
    from monoplot_plugin.gui import io_actions
    from monoplot_plugin.gui.dock import MonoplotDock

    win = iface.mainWindow()
    win.resize(1600, 1000)
    dem = QgsRasterLayer(str(DATA / "dem.tif"), "Aletsch DEM (25 m)")
    QgsProject.instance().addMapLayer(dem)
    QgsProject.instance().setCrs(QgsCoordinateReferenceSystem("EPSG:21781"))
    iface.mapCanvas().setExtent(dem.extent())
    dock = MonoplotDock(iface, win)
    iface.addDockWidget(Qt.DockWidgetArea.RightDockWidgetArea, dock)
    win.resizeDocks([dock], [760], Qt.Orientation.Horizontal)
    dock.show()
    state["dock"] = dock
    dock.photoFile.setFilePath(str(DATA / "photo.jpg"))
    dock.demCombo.setLayer(dem)
    c = dock.controller
    io_actions.load_camera_file(c, str(DATA / "prior_pose.kml"))
    dock.lens_panel.focal_spin.setValue(30.0)
    dock.lens_panel.apply()  # no sensor width yet: the note asks for it
    shot("inputs_1_lens_missing_sensor.png")
    dock.lens_panel.sensor_spin.setValue(22.2)
    dock.lens_panel.apply()
    shot("inputs_2_lens_applied.png")
    dock.io_actions.camera_button.menu().popup(dock.io_actions.camera_button.mapToGlobal(
        dock.io_actions.camera_button.rect().bottomLeft()))
    QTimer.singleShot(500, step2)


@guarded
def step2():
    dock = state["dock"]
    shot("inputs_3_camera_menu.png", dock.io_actions.camera_button.menu())
    dock.io_actions.camera_button.menu().hide()
    from monoplot_plugin.gui import io_actions

    c = dock.controller
    c.set_prior(c.prior.with_parameters(fov=63.08))  # the KML's field of view again
    io_actions.import_points_csv(c, str(DATA / "gcps.csv"))
    dock.stepTabs.setCurrentWidget(dock.pointsTab)
    photo = [p for p in c.state.in_space("photo")]
    c.select("photo", photo[4].id)
    QTimer.singleShot(6000, step3)  # the rough camera's DEM view renders in a task


@guarded
def step3():
    dock = state["dock"]
    shot("inputs_4_chips_rough_camera.png")
    shot("inputs_4b_chips_closeup.png", dock.chips)
    dock.stepTabs.setCurrentWidget(dock.fitTab)
    dock.fit_settings.setCollapsed(False)
    dock.fit_settings.free_checks["roll"].setChecked(False)
    dock.fit_settings.sigma_spins["position_sigma_m"].setValue(200.0)
    shot("inputs_5_fit_settings.png")
    c = dock.controller
    c.taskFinished.connect(step4)
    c.fit()


@guarded
def step4(result):
    dock = state["dock"]
    c = dock.controller
    report["fit"] = {k: c.state.fit_info.get(k) for k in ("status", "rmse_px", "mode", "free", "elapsed_s")}
    dock.stepTabs.setCurrentWidget(dock.pointsTab)
    photo = [p for p in c.state.in_space("photo")]
    c.select("photo", photo[4].id)
    QTimer.singleShot(1500, step5)


@guarded
def step5():
    dock = state["dock"]
    shot("inputs_6_chips_fitted.png")
    shot("inputs_6b_chips_fitted_closeup.png", dock.chips)
    finish()


QTimer.singleShot(1000, step1)
