"""Import and export in the real dock: GCP tables, point layers and camera files, both ways, on real files."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from qgis.core import Qgis, QgsProject, QgsRasterLayer

from monoplot_plugin.gui import io_actions
from monoplot_plugin.state import ACCEPTED, CHECK, MAP, PHOTO, REJECTED, remove_points
from monoplot_plugin.workflow.points_csv import read_points_csv, write_points_csv


def _load(dock, scene):
    dock.photoFile.setFilePath(scene.photo_path)
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    assert dock.controller.image is not None and dock.controller.dem is not None


def _surveyed(scene, n=12):
    """n GCPs of the scene whose surveyed Z differs from the DEM's by a few metres (as a GNSS survey would)."""
    xyz = scene.xyz[:n].copy()
    xyz[:, 2] += np.linspace(-6.0, 6.0, n)
    return scene.uv[:n], xyz


def test_gcp_csv_import_keeps_surveyed_z_and_check_flags(dock, scene, tmp_path):
    _load(dock, scene)
    c = dock.controller
    uv, xyz = _surveyed(scene)
    check = np.zeros(len(uv), bool)
    check[[1, 5, 9]] = True
    path = str(tmp_path / "gcps.csv")
    write_points_csv(path, uv=uv, xyz=xyz, ids=[f"g{i}" for i in range(len(uv))], check=check)
    assert io_actions.import_points_csv(c, path) == len(uv)
    assert len(c.state.pairs) == len(uv)
    assert len(c.state.check_pairs()) == 3 and len(c.state.valid_pairs()) == len(uv) - 3
    labels = {p.label for p in c.state.in_space(MAP)}
    assert labels == {f"g{i}" for i in range(len(uv))}
    # the fit gets the surveyed heights, not the DEM's
    photo, world, pairs = c.fit_inputs()
    order = np.argsort([p.label for p in c.state.in_space(MAP, (ACCEPTED,))])
    expected = xyz[~check]
    assert np.allclose(np.sort(world[:, 2]), np.sort(expected[:, 2]), atol=1e-3)
    dem_z = np.array([c.dem.sample(x, y) for x, y, _ in world])
    assert np.abs(world[:, 2] - dem_z).max() > 4.0 and len(pairs) == len(uv) - 3 and len(order) == len(pairs)
    ids, cuv, cxyz = c.check_points()
    assert np.allclose(np.sort(cxyz[:, 2]), np.sort(xyz[check, 2]), atol=1e-3)
    # the report names the points by the table's ids (a trial's P01-P10 came out numbered 1-8)
    assert sorted(c.report_checks().names) == ["g1", "g5", "g9"]
    c.fit_inputs()
    c.state.fit_info = {"status": "ok"}
    names = c.report_inputs()[0].names
    assert sorted(names) == sorted(f"g{i}" for i in range(len(uv)) if not check[i])
    # one undo entry takes the whole import back
    c.stack.undo()
    assert not c.state.points and not c.state.pairs


def test_the_menu_imports_a_gcp_table_as_check_points(dock, scene, tmp_path, monkeypatch):
    """The trial's Aletsch case: surveyed GCPs to measure a fit, not to fit on; one menu entry instead of a click
    and the C key on each."""
    _load(dock, scene)
    c = dock.controller
    uv, xyz = _surveyed(scene)
    path = str(tmp_path / "gcps.csv")
    write_points_csv(path, uv=uv, xyz=xyz, ids=[f"g{i}" for i in range(len(uv))])  # no check column
    monkeypatch.setattr(io_actions.QFileDialog, "getOpenFileName", staticmethod(lambda *a, **k: (path, "")))
    entry = next(a for a in dock.io_actions.points_button.menu().actions() if "every row a check point" in a.text())
    entry.trigger()
    assert len(c.state.check_pairs()) == len(uv) and not c.state.valid_pairs()
    inputs = c.fit_inputs()  # nothing of them goes into the fit: no points to fit (a message), or none of these
    assert isinstance(inputs, str) or len(inputs[0]) == 0


def test_a_gcp_table_fits_without_a_rough_camera(dock, scene, tmp_path, qtbot):
    """A desktop trial: 8 imported GCPs, and Fit said "Give a rough camera first" where fitcamera solves the same
    table from the pairs alone. Now the dock does too (6 or more pairs); fewer still ask for a rough camera."""
    _load(dock, scene)
    c = dock.controller
    uv, xyz = _surveyed(scene, 9)
    path = str(tmp_path / "gcps.csv")
    write_points_csv(path, uv=uv, xyz=xyz, check=[False] * 7 + [True] * 2)
    assert io_actions.import_points_csv(c, path) == 9 and c.prior is None and c.fitted is None
    messages = []
    c.message.connect(lambda text, level: messages.append(text))
    assert c.fit()
    with qtbot.waitSignal(c.taskFinished, timeout=60000) as blocker:
        pass
    assert blocker.args[0].ok, blocker.args[0].reason
    assert any("solved from the 7 pairs alone" in m for m in messages)
    info = c.state.fit_info
    assert info["mode"] == "paired" and info["n_check"] == 2 and info["check_rmse_px"] < 6.0, info["message"]
    assert np.linalg.norm(np.subtract(c.fitted.position, scene.camera.position)) < 30.0
    c.set_fitted(None, {})
    c.stack.undo()  # the import gone: no pairs, no camera
    write_points_csv(path, uv=uv[:5], xyz=xyz[:5])
    io_actions.import_points_csv(c, path)
    assert not c.fit() and "Give a rough camera first" in messages[-1]


def test_gcp_csv_export_round_trip(dock, scene, tmp_path):
    _load(dock, scene)
    c = dock.controller
    uv, xyz = _surveyed(scene, 8)
    src = str(tmp_path / "in.csv")
    write_points_csv(src, uv=uv, xyz=xyz, check=[i == 2 for i in range(8)])
    io_actions.import_points_csv(c, src)
    out = str(tmp_path / "out.csv")
    assert io_actions.export_points_csv(c, out) == 8
    back = read_points_csv(out)
    rows = sorted(zip(back["ids"], map(tuple, back["uv"]), map(tuple, back["xyz"]), back["check"]))
    want = sorted(zip([str(i + 1) for i in range(8)], map(tuple, uv), map(tuple, xyz), [i == 2 for i in range(8)]))
    for (i, a, b, k), (j, a2, b2, k2) in zip(rows, want):
        assert i == j and k == k2 and np.allclose(a, a2, atol=1e-3) and np.allclose(b, b2, atol=1e-3)


def test_bad_csv_is_a_message(dock, scene, tmp_path, qgis_iface):
    _load(dock, scene)
    messages = []
    dock.controller.message.connect(lambda text, level: messages.append(text))
    path = tmp_path / "bad.csv"
    path.write_text("a,b\n1,2\n")
    assert io_actions.import_points_csv(dock.controller, str(path)) == 0
    assert messages and "no point columns" in messages[-1]
    assert not dock.controller.state.points


def test_tables_from_other_tools_are_read_or_said_not_to_be(dock, scene, tmp_path):
    """A desktop trial's GCP tables: semicolons with decimal commas ("'u_px' is not a number"), image_x/image_y
    (8 map points, no word of the photo columns), E/N/H (8 photo points, no map), a u typed off the photo (counted,
    not named). Decimal commas and these names are read; a column still not read, and the row off the photo, are
    named."""
    _load(dock, scene)
    c = dock.controller
    messages = []
    c.message.connect(lambda text, level: messages.append(text))
    uv, xyz = scene.uv[:6], scene.xyz[:6]

    def table(name, header, rows):
        path = tmp_path / name
        path.write_text("\n".join([header] + rows) + "\n")
        return str(path)

    comma = table("semicolon.csv", "id;u_px;v_px;X;Y;Z", [f"g{i};{u:.2f};{v:.2f};{x:.2f};{y:.2f};{z:.2f}".replace(
        ".", ",") for i, ((u, v), (x, y, z)) in enumerate(zip(uv, xyz))])
    assert io_actions.import_points_csv(c, comma) == 6 and len(c.state.pairs) == 6
    got = np.array(sorted((p.x, p.y) for p in c.state.in_space(PHOTO)))
    assert np.allclose(got, np.array(sorted(map(tuple, uv))), atol=0.01)
    c.stack.undo()
    rows = [f"{u:.2f},{v:.2f},{x:.2f},{y:.2f},{z:.2f}" for (u, v), (x, y, z) in zip(uv, xyz)]
    for header in ("image_x,image_y,easting,northing,elevation", "col_px,row_px,E,N,H"):
        assert io_actions.import_points_csv(c, table("other.csv", header, rows)) == 6, messages[-1]
        assert len(c.state.pairs) == 6 and "Columns not read" not in messages[-1]
        c.stack.undo()
    io_actions.import_points_csv(c, table("unknown.csv", "pic_col,pic_row,X,Y,Z", rows))
    assert "Columns not read: pic_col, pic_row" in messages[-1] and not c.state.in_space(PHOTO)
    c.stack.undo()
    off = [f"G{i},{u + (1000 if i == 2 else 0):.2f},{v:.2f},{x:.2f},{y:.2f},{z:.2f}"
           for i, ((u, v), (x, y, z)) in enumerate(zip(uv, xyz))]
    io_actions.import_points_csv(c, table("off.csv", "id,u_px,v_px,X,Y,Z", off))
    assert "1 photo points lie outside the photo (G2): imported rejected, out of the fit" in messages[-1]
    # a typed u of 1720 on a 1500 px photo made a trial's fit "poor" (302 px): that pair is kept out of it
    g2 = [p for p in c.state.points.values() if p.label == "G2"]
    assert len(g2) == 2 and all(p.status == REJECTED for p in g2)
    assert len(c.state.valid_pairs()) == 5 and len(c.state.pairs) == 6
    c.stack.undo()
    bad = table("bad_number.csv", "u_px,v_px,X,Y,Z", ["12 px,3,4,5,6"])
    assert io_actions.import_points_csv(c, bad) == 0 and '\'u_px\' is "12 px", not a number' in messages[-1]


def test_a_table_imported_again_or_on_a_second_photo_adds_no_map_point_twice(dock, scene, tmp_path):
    """Repeat photography: each photo's GCP import added the same 11 map points again (11, 22, 33 ... accepted
    map points, all fitted); importing a table twice doubled every point."""
    _load(dock, scene)
    c = dock.controller
    messages = []
    c.message.connect(lambda text, level: messages.append(text))
    uv, xyz = _surveyed(scene, 6)
    src = str(tmp_path / "gcps.csv")
    write_points_csv(src, uv=uv, xyz=xyz)
    assert io_actions.import_points_csv(c, src) == 6
    undo_text = c.stack.undo_text()
    assert io_actions.import_points_csv(c, src) == 0  # the same rows: nothing new, and no empty undo entry
    assert "6 rows were imported before" in messages[-1] and c.stack.undo_text() == undo_text
    assert len(c.state.in_space(PHOTO)) == 6 and len(c.state.in_space(MAP)) == 6 and len(c.state.pairs) == 6
    # the table again with one surveyed height corrected: taken, said, undoable (a drone trial's re-import of its
    # corrected table kept the wrong height: "6 rows were imported before and are left as they are")
    fixed = xyz.copy()
    fixed[2, 2] -= 2.0
    write_points_csv(src, uv=uv, xyz=fixed)
    assert io_actions.import_points_csv(c, src) == 0
    heights = sorted(p.z for p in c.state.in_space(MAP))
    assert heights == pytest.approx(sorted(fixed[:, 2])) and len(c.state.in_space(MAP)) == 6
    assert messages[-1].startswith("gcps.csv: no new points.") and "0 photo" not in messages[-1], messages[-1]
    assert "Heights changed since the last import, taken (fit again): " in messages[-1], messages[-1]
    assert f"{xyz[2, 2]:.2f} → {fixed[2, 2]:.2f} m" in messages[-1]
    assert "5 rows were imported before" in messages[-1]
    c.stack.undo()
    assert sorted(p.z for p in c.state.in_space(MAP)) == pytest.approx(sorted(xyz[:, 2]))
    # the photo points go (another photo), the map points stay: a second table pairs its pixels with them
    c.stack.push(remove_points(c.state, [p.id for p in c.state.in_space(PHOTO)]))
    other = str(tmp_path / "modern.csv")
    write_points_csv(other, uv=uv * 0.8 + 5.0, xyz=xyz)
    assert io_actions.import_points_csv(c, other) == 6
    assert "6 map points were there already and are used again" in messages[-1]
    assert len(c.state.in_space(MAP)) == 6 and len(c.state.pairs) == 6
    maps = {p.id for p in c.state.in_space(MAP)}
    assert {m for _, m in c.state.pairs} == maps


def test_point_layers_export_and_import_round_trip(dock, scene, tmp_path):
    _load(dock, scene)
    c = dock.controller
    uv, xyz = _surveyed(scene, 6)
    src = str(tmp_path / "in.csv")
    write_points_csv(src, uv=uv, xyz=xyz, check=[i == 0 for i in range(6)])
    io_actions.import_points_csv(c, src)
    before = {(p.space, round(p.x, 3), round(p.y, 3), None if p.z is None else round(p.z, 3), p.status, p.label)
              for p in c.state.points.values()}
    photo_layer, map_layer = io_actions.export_point_layers(c, QgsProject.instance())
    assert photo_layer.featureCount() == 6 and map_layer.featureCount() == 6
    assert not photo_layer.crs().isValid() and map_layer.crs() == c.dem_crs
    c.stack.undo()
    assert not c.state.points
    assert io_actions.import_point_layers(c, [photo_layer, map_layer]) == 12
    after = {(p.space, round(p.x, 3), round(p.y, 3), None if p.z is None else round(p.z, 3), p.status, p.label)
             for p in c.state.points.values()}
    assert after == before
    assert len(c.state.pairs) == 6 and len(c.state.check_pairs()) == 1


def test_camera_json_and_kml_save_and_load(dock, scene, tmp_path, qtbot):
    _load(dock, scene)
    c = dock.controller
    c.set_fitted(scene.camera)
    c.set_prior(scene.prior)
    for suffix in ("json", "kml"):
        path = str(tmp_path / f"camera.{suffix}")
        assert io_actions.save_camera_file(c, path, "fitted")
        loaded = io_actions.load_camera_file(c, path, as_fitted=False)
        assert loaded is not None and c.prior is not None
        assert np.allclose(c.prior.position, scene.camera.position, atol=0.05)
        assert c.prior.heading == pytest.approx(scene.camera.heading, abs=1e-4)
        assert c.prior.fov == pytest.approx(scene.camera.fov, abs=1e-4)
    assert json.loads((tmp_path / "camera.json").read_text())["fov"] == pytest.approx(scene.camera.fov)


def test_processing_camera_json_loads_as_the_fitted_camera(dock, scene, tmp_path, qtbot):
    """Processing's fitcamera writes Camera.to_json: the dock loads it as its fitted camera, renders the overlay in
    a task and measures the check points on it."""
    _load(dock, scene)
    c = dock.controller
    uv, xyz = scene.uv[:6], scene.xyz[:6]
    src = str(tmp_path / "check.csv")
    write_points_csv(src, uv=uv, xyz=xyz, check=[True] * 6)
    io_actions.import_points_csv(c, src)
    path = tmp_path / "processing_camera.json"
    path.write_text(scene.camera.to_json())
    assert c.prior is None
    assert io_actions.load_camera_file(c, str(path), as_fitted=True) is not None
    assert c.fitted is not None and c.fitted.position == pytest.approx(scene.camera.position)
    # the camera tab says a fitted camera is there (a trial: "No rough camera yet" beside a loaded camera)
    assert dock.cameraSummary.text().startswith("A fitted camera is loaded")
    assert c.state.fit_info["n_check"] == 6 and c.state.fit_info["check_rmse_px"] < 1.0
    assert c.state.fit_info["status"] == "ok"  # verified by the 6 check points
    qtbot.waitUntil(lambda: c.overlay is not None and c.xyz is not None, timeout=30000)
    assert "Check points" in dock.resultLabel.text()
    # a camera 200 m off, loaded as the fitted one: the check points say it is wrong (not a green "ok")
    path.write_text(scene.camera.with_parameters(x=scene.camera.position[0] + 200.0).to_json())
    assert io_actions.load_camera_file(c, str(path), as_fitted=True) is not None
    assert c.state.fit_info["status"] in ("poor", "uncertain")
    # without check points nothing has verified a loaded camera: "uncertain", and the message says what to do
    c.set_status([p.id for p in c.state.points.values()], "accepted")
    path.write_text(scene.camera.to_json())
    assert io_actions.load_camera_file(c, str(path), as_fitted=True) is not None
    assert c.state.fit_info["status"] == "uncertain" and "check points" in c.state.fit_info["message"]
    # ... but the pairs already there are measured on it (the header showed "RMSE -, 0 photo / 0 DEM points")
    info = c.state.fit_info
    assert info["n_pairs"] == 6 and info["rmse_px"] < 1.0 and "6 pairs already there" in info["message"], info
    # the camera tab shows the fitted camera's lens and pitch (a trial: 60° and 0°, the defaults, beside it)
    path.write_text(scene.camera.with_parameters(fov=52.5, pitch=-6.5).to_json())
    assert io_actions.load_camera_file(c, str(path), as_fitted=True) is not None
    assert (dock.fovSpin.value(), dock.pitchSpin.value()) == pytest.approx((52.5, -6.5), abs=0.05)


def test_camera_of_another_photo_size_is_scaled_or_kept_as_a_rough_start(dock, scene, tmp_path):
    _load(dock, scene)
    c = dock.controller
    messages = []
    c.message.connect(lambda text, level: messages.append(text))
    # the same picture saved at half the resolution: its camera, scaled back, projects as the photo's own
    half = tmp_path / "half.json"
    half.write_text(scene.camera.scaled(0.5).to_json())
    loaded = io_actions.load_camera_file(c, str(half), as_fitted=True)
    assert loaded is not None and loaded.image_size == c.photo_size and "scaled to the photo's" in messages[-1]
    assert np.abs(loaded.project(scene.xyz) - scene.camera.project(scene.xyz)).max() < 1.0
    # a crop (another shape): refused as the fitted camera, kept as a rough start, each message saying so
    w, h = scene.camera.image_size
    crop = tmp_path / "crop.json"
    crop.write_text(dataclasses.replace(scene.camera, image_size=(w, int(h * 1.3))).to_json())
    assert io_actions.load_camera_file(c, str(crop), as_fitted=True) is None
    assert "another shape" in messages[-1] and "rough camera" in messages[-1]
    prior = io_actions.load_camera_file(c, str(crop))
    assert prior is not None and c.prior.image_size == c.photo_size and "rough start" in messages[-1]
    assert c.prior.position == scene.camera.position and c.prior.fov == scene.camera.fov


def test_dock_menus_are_there(dock):
    assert dock.io_actions.camera_button.menu().actions()
    assert dock.io_actions.points_button.menu().actions()


def test_aletsch_gcps_with_surveyed_z_fit_in_the_dock_as_in_processing(qgis_iface, qtbot, aletsch_dir):
    """The issue's case: the 11 GCPs clicked one by one took Z from the DEM (10.4 px); imported with their surveyed Z
    the dock's paired fit reaches what Processing reaches on the same table (about 7.7 px)."""
    from monoplot_plugin.gui.dock import MonoplotDock

    project = QgsProject.instance()
    project.clear()
    layer = QgsRasterLayer(str(aletsch_dir / "dem.tif"), "Aletsch DEM")
    assert layer.isValid()
    project.addMapLayer(layer)
    d = MonoplotDock(qgis_iface)
    qtbot.addWidget(d)
    try:
        d.photoFile.setFilePath(str(aletsch_dir / "photo.jpg"))
        d.demCombo.setLayer(layer)
        c = d.controller
        assert io_actions.load_camera_file(c, str(aletsch_dir / "prior_pose.kml")) is not None
        assert io_actions.import_points_csv(c, str(aletsch_dir / "gcps.csv")) == 11
        table = read_points_csv(str(aletsch_dir / "gcps.csv"))
        _, world, pairs = c.fit_inputs()
        assert len(pairs) == 11
        assert np.allclose(np.sort(world[:, 2]), np.sort(table["xyz"][:, 2]), atol=1e-3)
        assert c.fit()
        with qtbot.waitSignal(c.taskFinished, timeout=120000) as blocker:
            pass
        assert blocker.args[0].ok, blocker.args[0].reason
        assert c.state.fit_info["mode"] == "paired"
        assert c.state.fit_info["rmse_px"] < 8.5
        assert "px on 11 pairs." in d.statusLabel.text(), d.statusLabel.text()  # what the paired fit used
    finally:
        d.controller.cancel()
        if d.controller.task is not None:
            qtbot.waitUntil(lambda: d.controller.task is None, timeout=10000)
        d.unload()
        project.clear()


def test_unpaired_photo_only_table(dock, scene, tmp_path):
    _load(dock, scene)
    c = dock.controller
    path = str(tmp_path / "photo.csv")
    write_points_csv(path, uv=scene.uv[:5])
    assert io_actions.import_points_csv(c, path) == 5
    assert all(p.space == PHOTO and p.status == ACCEPTED for p in c.state.points.values())
    assert not c.state.pairs and CHECK not in {p.status for p in c.state.points.values()}


def test_gcp_table_of_a_dem_in_degrees_round_trips_in_degrees(dock, tmp_path, qtbot):
    """A DEM in degrees is used in UTM metres: its table is read in degrees (the file's CRS) and written back so."""
    from osgeo import osr

    from monoplot_plugin.core.dem import Dem

    wgs84 = osr.SpatialReference()
    wgs84.ImportFromEPSG(4326)
    rows, cols = np.mgrid[0:120, 0:120]
    hills = 1500.0 + 300.0 * np.sin(rows / 9.0) * np.cos(cols / 13.0)
    dem = Dem.from_array(hills, (8.0, 0.0005, 0.0, 46.56, 0.0, -0.0005), crs_wkt=wgs84.ExportToWkt())
    path = str(tmp_path / "dem_degrees.tif")
    dem.save(path)
    layer = QgsRasterLayer(path, "DEM in degrees")
    assert layer.isValid() and layer.crs().isGeographic()
    QgsProject.instance().addMapLayer(layer)
    c = dock.controller
    assert c.set_dem_layer(layer) and c.dem.source_crs_wkt  # reprojected to UTM
    from monoplot_plugin.adapters.photo import array_to_qimage

    photo = str(tmp_path / "p.png")
    assert array_to_qimage(np.zeros((200, 300, 3), np.uint8)).save(photo)
    assert c.load_photo(photo)
    x0, y0, x1, y1 = dem.bounds()
    lonlat = np.array([[x0 + (x1 - x0) * f, y0 + (y1 - y0) * g, 1000.0 + 100 * f] for f, g in
                       ((0.2, 0.3), (0.5, 0.5), (0.7, 0.8), (0.4, 0.6))])
    src = str(tmp_path / "gcps_degrees.csv")
    write_points_csv(src, uv=np.array([[10, 20], [50, 60], [100, 120], [200, 150.0]]), xyz=lonlat)
    assert io_actions.import_points_csv(c, src) == 4
    world = np.array([(p.x, p.y) for p in c.state.in_space(MAP)])
    x0u, y0u, x1u, y1u = c.dem.bounds()
    assert ((world[:, 0] > x0u) & (world[:, 0] < x1u) & (world[:, 1] > y0u) & (world[:, 1] < y1u)).all()  # metres
    out = str(tmp_path / "out.csv")
    assert io_actions.export_points_csv(c, out) == 4
    back = read_points_csv(out)
    order = np.argsort(back["uv"][:, 0])
    assert np.allclose(back["xyz"][order], lonlat, atol=1e-6)  # degrees again (1e-6 deg: < 0.1 m), Z as given


def test_check_points_imported_after_a_fit_measure_it_at_once(dock, scene, tmp_path, qtbot):
    """The desktop trial imported its GCP table as check points after the fit: the summary kept "ok, RMSE 7.7 px on
    11 pairs" with no check-point line until Fit was pressed again. Now they measure the camera at once, lower its
    status when they disagree with it, and an undo takes that back."""
    _load(dock, scene)
    c = dock.controller
    c.set_fitted(scene.camera, {"status": "ok", "rmse_px": 0.5, "mode": "paired", "n_pairs": 12, "n_photo": 12,
                                "message": "fitted."})
    assert "Check points" not in dock.resultLabel.text()
    messages = []
    c.message.connect(lambda text, level: messages.append(text))
    uv, xyz = scene.uv[:6], scene.xyz[:6]
    good = str(tmp_path / "good.csv")
    write_points_csv(good, uv=uv, xyz=xyz, ids=[f"c{i}" for i in range(6)])
    io_actions.import_points_csv(c, good, all_check=True)
    info = c.state.fit_info
    assert info["n_check"] == 6 and info["check_rmse_px"] < 0.5 and info["status"] == "ok"
    assert "Check points" in dock.resultLabel.text()
    # said after the import's own summary, which replaced it at once in the message bar (desktop trial)
    qtbot.waitUntil(lambda: any("Check points: " in m for m in messages), timeout=2000)
    assert "Check points: " in messages[-1] and any(m.startswith("good.csv") for m in messages[:-1])
    c.stack.undo()
    # the same points 60 px off: the camera is not what they say
    bad = str(tmp_path / "bad.csv")
    write_points_csv(bad, uv=uv + 60.0, xyz=xyz, ids=[f"c{i}" for i in range(6)])
    io_actions.import_points_csv(c, bad, all_check=True)
    assert c.state.fit_info["check_rmse_px"] > 50 and c.state.fit_info["status"] != "ok"
    shown = dock.resultLabel.text()
    assert f">{c.state.fit_info['status']}</b> · Check points <b>{c.state.fit_info['check_rmse_px']:.1f} px" in shown
    c.stack.undo()  # no check points any more: the fit's own status again
    assert c.state.fit_info["status"] == "ok" and c.state.fit_info["check_rmse_px"] is None
    # Off by 1 % of the picture, many times the fit's residuals: under the 1.5 % that makes a camera "uncertain"
    # alone, but the residuals flatter it, as a fit with them would say (a drone trial: 8 surveyed check points at
    # 50 px on a 7.7 px fit, and the dock said "camera status ok")
    shift = 0.01 * math.hypot(*scene.camera.image_size) / math.sqrt(2.0)
    near = str(tmp_path / "near.csv")
    write_points_csv(near, uv=uv + shift, xyz=xyz, ids=[f"c{i}" for i in range(6)])
    io_actions.import_points_csv(c, near, all_check=True)
    assert c.state.fit_info["status"] == "uncertain", c.state.fit_info["message"]
    assert "times the camera's residuals" in c.state.fit_info["message"]
    assert "(uncertain)" in dock.countsLabel.text() and "(ok)" not in dock.countsLabel.text()  # the points tab too
    c.stack.undo()
    assert c.state.fit_info["status"] == "ok" and "(ok)" in dock.countsLabel.text()
    # Two that agree are too few to verify a camera alone, but lower nothing the fit verified (a trial: "uncertain"
    # when imported after the fit, "ok" when imported before it, as a fit judges them)
    two = str(tmp_path / "two.csv")
    write_points_csv(two, uv=uv[:2], xyz=xyz[:2], ids=["c0", "c1"])
    io_actions.import_points_csv(c, two, all_check=True)
    info = c.state.fit_info
    assert info["n_check"] == 2 and info["check_rmse_px"] < 0.5 and info["status"] == "ok", info["message"]
    # More of them, the status unchanged: the message bar says so too (a trial's bar kept "RMSE on 1" at 7)
    messages.clear()
    more = str(tmp_path / "more.csv")
    write_points_csv(more, uv=uv[2:5], xyz=xyz[2:5], ids=["c2", "c3", "c4"])
    io_actions.import_points_csv(c, more, all_check=True)
    assert c.state.fit_info["n_check"] == 5 and c.state.fit_info["status"] == "ok"
    qtbot.waitUntil(lambda: any("Check points: " in m for m in messages), timeout=2000)
    assert " on 5;" in [m for m in messages if "Check points: " in m][-1]


def test_a_camera_written_with_its_verdict_comes_back_with_it(dock, scene, tmp_path):
    """The dock's Save fitted camera keeps the fit's verdict in the JSON; a camera its own fit called poor loads as
    poor (not the "uncertain" of any unchecked camera), the message saying why."""
    from monoplot_plugin.workflow.camera_files import camera_json

    _load(dock, scene)
    c = dock.controller
    said = []
    c.message.connect(lambda text, level: said.append((text, level)))
    poor = tmp_path / "poor.json"
    poor.write_text(camera_json(scene.camera, {"status": "poor", "message": "the skyline disagrees",
                                               "sigma": {"x": 210.0, "heading": 1.5}}))
    assert io_actions.load_camera_file(c, str(poor), as_fitted=True) is not None
    info = c.state.fit_info
    assert info["status"] == "poor" and 'verdict was "poor": the skyline disagrees' in info["message"]
    # the bar says it too, as a warning (a trial's "uncertain" camera loaded with a blue "Fitted camera loaded.")
    assert '"poor"' in said[-1][0] and said[-1][1] == Qgis.MessageLevel.Warning, said
    # its σ says how doubtful (a trial's reloaded "uncertain" camera showed no ± though its file held them)
    assert info["sigma"] == {"x": 210.0, "heading": 1.5} and "±\u00a0210" in dock.resultLabel.text()
    saved = tmp_path / "saved.json"
    assert io_actions.save_camera_file(c, str(saved))
    assert json.loads(saved.read_text())["fit"]["status"] == "poor"
    # An "ok" written with its σ (a trial: the dock's own saved "ok" camera came back "uncertain" in a new project,
    # and the flood line drawn on it had no xy error): its verdict and σ come back, said to be the file's.
    ok = tmp_path / "ok.json"
    ok.write_text(camera_json(scene.camera, {"status": "ok", "message": "paired fit on 6 pairs: RMSE 0.5 px.",
                                             "sigma": {"x": 0.48, "heading": 0.0079}, "mode": "paired",
                                             "rmse_px": 0.5, "loo_rmse_px": 1.2}))
    assert io_actions.load_camera_file(c, str(ok), as_fitted=True) is not None
    info = c.state.fit_info
    assert info["status"] == "ok" and info["sigma"] == {"x": 0.48, "heading": 0.0079}
    # a feature drawn on it gets an xy_error_m from its fit's figures (a re-check trial's had none)
    from monoplot_plugin.workflow.features import pixel_error
    assert pixel_error(info) == (1.2, "loo")
    assert "own fit's verdict" in info["message"] and "6 pairs" in info["message"]
    assert "Loaded with its own fit" in dock.resultLabel.text()
    assert io_actions.save_camera_file(c, str(saved))  # and it goes out again as it came
    assert json.loads(saved.read_text())["fit"]["sigma"] == {"x": 0.48, "heading": 0.0079}


def test_an_ok_camera_fitted_on_another_photo_loads_uncertain(dock, scene, tmp_path, qtbot):
    """A time-lapse trial loaded frame 1's "ok" camera onto frame 5 (the mount turned 4 degrees): the dock said "ok",
    and a front drawn on it was 168 m off where its error figure said 6.9 m. The saved camera names its photo; on
    the same photo it comes back "ok", on another (same size and name) "uncertain", saying why."""
    import shutil

    from monoplot_plugin.core.synthetic import render_photo
    from monoplot_plugin.adapters.photo import array_to_qimage
    from monoplot_plugin.workflow.camera_files import camera_json

    frames = tmp_path / "frame1", tmp_path / "frame5"
    for folder in frames:
        folder.mkdir()
    shutil.copy(scene.photo_path, frames[0] / "photo.png")
    turned = scene.camera.with_parameters(heading=scene.camera.heading + 4.0)
    assert array_to_qimage(render_photo(turned, scene.dem)).save(str(frames[1] / "photo.png"))
    dock.photoFile.setFilePath(str(frames[0] / "photo.png"))
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    c = dock.controller
    verdict = {"status": "ok", "message": "paired fit on 6 pairs: RMSE 0.5 px.", "sigma": {"heading": 0.008},
               "mode": "paired", "rmse_px": 0.5, "loo_rmse_px": 1.2}
    c.set_fitted(scene.camera, verdict, background=False)
    saved = tmp_path / "frame1_camera.json"
    assert io_actions.save_camera_file(c, str(saved))
    fit = json.loads(saved.read_text())["fit"]
    assert fit["photo"] == "photo.png" and len(fit["photo_sha256"]) == 64
    assert io_actions.load_camera_file(c, str(saved), as_fitted=True) is not None
    assert c.state.fit_info["status"] == "ok"  # the photo it was fitted on
    from test_photo_change import answer_with

    answer_with(qtbot, "Start afresh", [])  # the question asked when the photo changes under a fitted camera
    dock.photoFile.setFilePath(str(frames[1] / "photo.png"))
    assert c.state.photo_path == str(frames[1] / "photo.png")
    said = []
    c.message.connect(lambda text, level: said.append((text, level)))
    assert io_actions.load_camera_file(c, str(saved), as_fitted=True) is not None
    info = c.state.fit_info
    assert info["status"] == "uncertain" and "fitted on another photo (photo.png)" in info["message"]
    assert any("\"uncertain\" here, it was fitted on another photo" in m and level == Qgis.MessageLevel.Warning
               for m, level in said)  # in the message bar too: the camera tab says nothing of the fit
    assert info["sigma"] == {"heading": 0.008}
    from monoplot_plugin.workflow.features import pixel_error
    assert pixel_error(info) == (None, "")  # no error figure on the ground for features drawn on it
    # a camera file written without a photo (a fit on points alone) keeps its verdict, as before
    bare = tmp_path / "bare.json"
    bare.write_text(camera_json(scene.camera, verdict))
    assert io_actions.load_camera_file(c, str(bare), as_fitted=True) is not None
    assert c.state.fit_info["status"] == "ok"


def test_a_gcp_table_in_the_projects_crs_is_converted_and_one_off_the_dem_is_a_warning(dock, scene, tmp_path):
    """A trial: a GCP table in the project's CRS (LV95) was read as the DEM's (LV03): the 11 points lay 2,200 km
    away, the message said only "11 pairs", the fit said "ok" and the XYZ raster was empty."""
    from qgis.core import QgsCoordinateReferenceSystem

    from monoplot_plugin.workflow.inputs import _transform

    _load(dock, scene)
    c = dock.controller
    messages = []
    c.message.connect(lambda text, level: messages.append((text, level)))
    uv, xyz = _surveyed(scene, 6)
    project = QgsProject.instance()
    project.setCrs(QgsCoordinateReferenceSystem("EPSG:3857"))
    in_project_crs = _transform(xyz, c.dem.crs_wkt, "EPSG:3857")
    assert np.abs(in_project_crs[:, :2] - xyz[:, :2]).max() > 1e5  # other numbers altogether
    path = str(tmp_path / "gcps_3857.csv")
    write_points_csv(path, uv=uv, xyz=in_project_crs)
    assert io_actions.import_points_csv(c, path) == 6
    world = np.array([(p.x, p.y) for p in c.state.in_space(MAP)])
    assert np.abs(np.sort(world, axis=0) - np.sort(xyz[:, :2], axis=0)).max() < 0.01  # back on the DEM
    text, level = messages[-1]
    assert "were converted to the DEM's CRS" in text and "EPSG:3857" in text, text
    c.stack.undo()
    # numbers in no CRS it knows (shifted by 2,000 km): imported as given, with a warning
    shifted = xyz.copy()
    shifted[:, 0] += 2e6
    path = str(tmp_path / "gcps_shifted.csv")
    write_points_csv(path, uv=uv, xyz=shifted)
    assert io_actions.import_points_csv(c, path) == 6
    text, level = messages[-1]
    assert "6 of 6 map points" in text and "outside the DEM" in text and level == io_actions.WARNING, text
    c.stack.undo()
    write_points_csv(path, uv=uv, xyz=xyz)  # on the DEM: no warning
    io_actions.import_points_csv(c, path)
    assert "outside the DEM" not in messages[-1][0] and messages[-1][1] != io_actions.WARNING
    project.setCrs(QgsCoordinateReferenceSystem())


def test_a_fitted_camera_that_sees_no_dem_is_a_warning(dock, scene):
    """A trial's fit to a GCP table in another CRS said "ok" (its points agreed) for a camera 2,200 km from the DEM,
    and nothing said so until a product was refused."""
    import dataclasses

    from monoplot_plugin.gui import engine

    _load(dock, scene)
    c = dock.controller
    messages = []
    c.message.connect(lambda text, level: messages.append((text, level)))
    x, y, z = scene.camera.position
    far = dataclasses.replace(scene.camera, position=(x + 2e6, y, z))
    overlay, xyz, footprint = engine.render_products(far, c.dem)
    info = {"status": "ok", "mode": "paired", "rmse_px": 2.0, "n_pairs": 6, "message": "paired fit"}
    c.show_fit(engine.FitOutcome(far, info, overlay, xyz, footprint))
    assert any("sees no part of the DEM" in t and level == io_actions.WARNING for t, level in messages), messages
    messages.clear()
    overlay, xyz, footprint = engine.render_products(scene.camera, c.dem)
    c.show_fit(engine.FitOutcome(scene.camera, info, overlay, xyz, footprint))
    assert not any("sees no part of the DEM" in t for t, _ in messages)


def test_a_swiss_table_with_y_east_and_x_north_is_read_right(dock, scene, tmp_path):
    """A Swiss trial's GCP table, as a German Excel saves it: "Punkt;u_px;v_px;Y;X;H" (Y the easting, X the
    northing), thousands as 642'691.951, a decimal comma, Windows-1252 with ‘quotes’ and umlauts in the names. All
    11 points fell off the DEM ("are their X, Y in the DEM's CRS?"), the fit was "poor", the names became 1..11 and
    the quotes control codes."""
    _load(dock, scene)
    c = dock.controller
    messages = []
    c.message.connect(lambda text, level: messages.append(text))
    uv, xyz = _surveyed(scene, 6)

    def swiss(value: float) -> str:
        whole, frac = f"{value:.3f}".split(".")
        groups = f"{int(whole):,}".replace(",", "'")
        return f"{groups}.{frac}"

    names = [f"‘Grät {i}’ – Märjelen" for i in range(6)]
    lines = ["Punkt;u_px;v_px;Y;X;H"] + [
        f"{n};{u:.2f};{v:.2f};{swiss(x)};{swiss(y)};{z:.1f}".replace(f"{u:.2f}", f"{u:.2f}".replace(".", ","))
        for n, (u, v), (x, y, z) in zip(names, uv, xyz)]
    path = tmp_path / "GCP Märjelen.csv"
    path.write_bytes(("\r\n".join(lines) + "\r\n").encode("cp1252"))
    assert io_actions.import_points_csv(c, str(path)) == 6
    world = {p.label: (p.x, p.y) for p in c.state.in_space(MAP)}
    assert sorted(world) == sorted(names)  # the names as written, quotes and all
    got = np.array([world[n] for n in names])
    assert np.abs(got - xyz[:, :2]).max() < 0.01  # on the DEM: X and Y swapped back
    assert any("X and Y the other way round" in m and "were swapped" in m for m in messages), messages


def test_a_table_with_u_and_v_the_other_way_round_is_read_right(dock, scene, tmp_path):
    """A trial's table with v first: 5 of its 12 rows off the photo came in rejected, the other 7 fitted wrong."""
    _load(dock, scene)
    c = dock.controller
    messages = []
    c.message.connect(lambda text, level: messages.append(text))
    uv, xyz = _surveyed(scene, 12)
    assert (uv[:, 0] > c.photo_size[1]).sum() >= 2  # as given (v, u), those rows lie below the photo
    path = str(tmp_path / "gcps.csv")
    write_points_csv(path, uv=uv[:, ::-1], xyz=xyz, ids=[f"g{i}" for i in range(12)])
    assert io_actions.import_points_csv(c, path) == 12
    photo = {p.label: (p.x, p.y) for p in c.state.in_space(PHOTO, (ACCEPTED,))}
    assert len(photo) == 12 and np.abs(np.array([photo[f"g{i}"] for i in range(12)]) - uv).max() < 0.01
    assert "u and v the other way round" in messages[-1] and "lie outside the photo" not in messages[-1]


def test_a_camera_that_sees_no_dem_gets_no_advice_on_its_position_or_lens(dock, scene):
    """A re-check trial's "poor" camera, 4,575 km from the DEM (its GCP table in another CRS), was told to fix its
    position in the fit settings: the points' CRS is the cause, which the fit's own message names."""
    c = dock.controller
    info = {"status": "poor", "moved_m": 4574673.0, "position_sigma_m": 100.0, "fov_deg": 60.0,
            "prior_fov_deg": 60.0, "fov_sigma_deg": 6.0}
    assert "moved the camera 4574673 m" in c.moved_advice(info)
    assert c.moved_advice({**info, "sees_no_terrain": True}) == ""
