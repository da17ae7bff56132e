"""Inputs through the dock on real files: EXIF orientation, geographic DEM, KML prior, rough camera drawn by a drag,
linked cursor from the map ("hidden" behind terrain)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from qgis.core import Qgis, QgsPointXY, QgsProject, QgsRasterLayer
from qgis.PyQt.QtCore import QPoint, Qt
from qgis.PyQt.QtGui import QColor, QImage, QImageIOHandler, QImageWriter



def test_exif_orientation_is_honoured(dock, tmp_path):
    image = QImage(60, 40, QImage.Format.Format_RGB32)
    image.fill(QColor(200, 30, 30))
    path = str(tmp_path / "rotated.jpg")
    writer = QImageWriter(path)
    writer.setTransformation(QImageIOHandler.Transformation.TransformationRotate90)  # EXIF orientation 6
    assert writer.write(image)
    dock.photoFile.setFilePath(path)
    assert dock.controller.photo_size == (40, 60)  # as the user sees it, not as stored
    assert dock.photo_canvas.photo_size == (40, 60)


def test_geographic_dem_is_reprojected_with_a_message(dock, scene, tmp_path, qgis_iface):
    from osgeo import gdal

    path = str(tmp_path / "dem_wgs84.tif")
    gdal.Warp(path, scene.dem_path, dstSRS="EPSG:4326")
    layer = QgsRasterLayer(path, "DEM in degrees")
    QgsProject.instance().addMapLayer(layer)
    dock.demCombo.setLayer(layer)
    dem = dock.controller.dem
    assert dem is not None and "UTM" in dem.crs_wkt
    assert abs(dem.geotransform[1]) > 10  # metres, not degrees
    infos = qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Info)
    assert any("degrees" in m for m in infos)


def test_kml_prior_import(dock, scene, tmp_path):
    from osgeo import osr

    dock.photoFile.setFilePath(scene.photo_path)
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    src = osr.SpatialReference()
    src.ImportFromWkt(scene.dem.crs_wkt)
    dst = osr.SpatialReference()
    dst.ImportFromEPSG(4326)
    dst.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    src.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    lon, lat, _ = osr.CoordinateTransformation(src, dst).TransformPoint(*scene.camera.position[:2])
    kml = tmp_path / "prior.kml"
    kml.write_text(f"""<kml><PhotoOverlay><Camera><longitude>{lon}</longitude><latitude>{lat}</latitude>
        <altitude>{scene.camera.position[2]}</altitude><heading>2</heading><tilt>86</tilt><roll>0</roll></Camera>
        <ViewVolume><leftFov>-30</leftFov><rightFov>30</rightFov><bottomFov>-20</bottomFov><topFov>20</topFov>
        </ViewVolume></PhotoOverlay></kml>""")
    assert dock.controller.import_kml(str(kml))
    prior = dock.controller.prior
    assert math.dist(prior.position[:2], scene.camera.position[:2]) < 1.0
    assert abs(prior.pitch + 4.0) < 1e-6 and abs(prior.fov - 60.0) < 1e-6
    assert "Rough camera" in dock.cameraSummary.text()
    assert not dock.map_view.prior_band.band.asGeometry().isEmpty()  # the wedge is drawn at once
    # a KML camera without a field of view (no <ViewVolume>: Google Earth's camera alone) takes the box's, and says
    # so (a trial: refused, "KML has no <leftFov> element", the box beside it)
    bare = tmp_path / "bare.kml"
    bare.write_text(f"""<kml><Camera><longitude>{lon}</longitude><latitude>{lat}</latitude>
        <altitude>{scene.camera.position[2]}</altitude><heading>2</heading><tilt>86</tilt></Camera></kml>""")
    dock.fovSpin.setValue(47.0)
    messages = []
    dock.controller.message.connect(lambda text, level: messages.append(text))
    assert dock.io_actions.open_camera(str(bare))
    assert dock.controller.prior.fov == pytest.approx(47.0) and "no field of view" in messages[-1]
    dock.controller.set_prior(prior)
    # The map's CRS changes after the wedge was drawn (QGIS takes the project's CRS from the first layer a moment
    # after it is added): the wedge follows, its apex still at the camera.
    from qgis.core import QgsCoordinateReferenceSystem, QgsCoordinateTransform

    canvas = dock.map_canvas
    for crs in (QgsCoordinateReferenceSystem("EPSG:4326"), QgsCoordinateReferenceSystem("EPSG:3857")):
        canvas.setDestinationCrs(crs)
        apex = QgsCoordinateTransform(dock.controller.dem_crs, crs, QgsProject.instance()).transform(
            QgsPointXY(*prior.position[:2]))
        box = dock.map_view.prior_band.band.asGeometry().boundingBox()
        assert box.buffered(1e-6 * max(box.width(), box.height())).contains(apex), (crs.authid(), box, apex)


def test_a_rough_camera_deep_under_the_dem_is_said_to_have_a_wrong_height(dock, scene, tmp_path, qgis_iface):
    """A trial's camera JSON stood 29 m under the terrain: "Rough camera loaded" alone, then the fit pinned it on the
    ground at 0 m. The import says the height is wrong; a camera above the DEM gets no such words."""
    from monoplot_plugin.gui.io_actions import load_camera_file
    from monoplot_plugin.workflow.camera_files import save_camera

    dock.photoFile.setFilePath(scene.photo_path)
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    ground = float(scene.dem.sample(*scene.camera.position[:2]))
    for name, height in (("under.json", -35.0), ("above.json", 60.0)):
        path = str(tmp_path / name)
        save_camera(path, scene.camera.with_parameters(z=ground + height))
        before = len(qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Warning))
        assert load_camera_file(dock.controller, path) is not None
        warned = [m for m in qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Warning)[before:]
                  if "under the DEM" in m]
        assert len(warned) == (height < 0), (name, warned)
        if warned:
            assert "35 m under the DEM" in warned[0] and "Above ground" in warned[0]


def test_pairs_lift_a_rough_camera_held_under_the_dem_and_the_dock_says_so(dock, scene, tmp_path, qtbot):
    """A desktop trial: a rough camera 29 m under the DEM and good GCPs; the dock's fit held it on the ground, 37 m
    off. Now the pairs free its height, and the message bar says so (the import had said it would be held)."""
    from monoplot_plugin.gui.io_actions import import_points_csv, load_camera_file
    from monoplot_plugin.workflow.camera_files import save_camera
    from monoplot_plugin.workflow.points_csv import write_points_csv

    dock.photoFile.setFilePath(scene.photo_path)
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    c = dock.controller
    ground = float(scene.dem.sample(*scene.prior.position[:2]))
    path = str(tmp_path / "under.json")
    save_camera(path, scene.prior.with_parameters(z=ground - 29.0))
    assert load_camera_file(c, path) is not None
    gcps = str(tmp_path / "gcps.csv")
    write_points_csv(gcps, uv=scene.uv[:12], xyz=scene.xyz[:12])
    import_points_csv(c, gcps)
    said = []
    c.message.connect(lambda text, level: said.append(text))
    with qtbot.waitSignal(c.taskFinished, timeout=120000):
        dock.fitButton.click()
    info = c.state.fit_info
    assert info["mode"] == "paired" and info["height_freed"] and not info["on_ground"], info
    assert info["clearance_m"] == pytest.approx(300.0, abs=5.0) and info["rmse_px"] < 1.0
    assert any("its height was fitted freely" in text for text in said), said


def test_a_prints_border_gets_no_relief_overlay_and_no_ground_under_the_cursor(dock, scene, tmp_path, qtbot):
    """A trial's scanned print: the dock drew the DEM relief over the paper border and the caption, and the cursor
    gave map coordinates there, while the products leave them out. The dock now leaves them out too."""
    import cv2

    from monoplot_plugin.gui.io_actions import load_camera_file

    photo = cv2.imread(scene.photo_path)
    h, w = photo.shape[:2]
    photo[:20], photo[-60:], photo[:, :20], photo[:, -20:] = (235, 246, 250), (235, 246, 250), (235, 246, 250), \
        (235, 246, 250)  # cream paper (BGR)
    cv2.putText(photo, "Das Grosse Tal 1891 No 4127", (40, h - 22), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (20, 20, 20), 2)
    printed = str(tmp_path / "print.png")
    cv2.imwrite(printed, photo)
    dock.photoFile.setFilePath(printed)
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    c = dock.controller
    path = tmp_path / "camera.json"
    path.write_text(scene.camera.to_json())
    assert load_camera_file(c, str(path), as_fitted=True) is not None
    qtbot.waitUntil(lambda: c.overlay is not None and c.xyz is not None, timeout=30000)
    overlay = c.overlay
    oh, ow = overlay.height(), overlay.width()
    alpha = np.array([[overlay.pixelColor(x, y).alpha() for x in range(ow)] for y in range(oh)])
    assert alpha[oh // 2, ow // 2] > 0  # the picture: relief
    assert not alpha[: max(1, oh * 10 // h)].any() and not alpha[-(oh * 50 // h):].any()  # the paper: none
    assert c.ground_at_pixel(w / 2, h / 2) is not None
    assert c.ground_at_pixel(w / 2, 8) is None and c.ground_at_pixel(w / 2, h - 10) is None
    # map -> photo: ground the camera sees on the caption's paper is not "visible in the photo" (a re-check trial)
    from monoplot_plugin.core.transforms import photo_points_to_map

    ground = photo_points_to_map(np.array([[w / 2, h - 10.0], [w / 2, h / 2]]), scene.camera, c.dem)[0]
    assert np.isfinite(ground).all()
    assert c.pixel_of_ground(*ground[0][:2])[1] == "outside" and c.pixel_of_ground(*ground[1][:2])[1] == "visible"
    # a rough camera of a print looks through its picture's centre, not the scan's (the border is uneven: 20 px on
    # top, 60 under it); a fitted camera loaded from a file keeps its own
    said = []
    c.message.connect(lambda text, level: said.append(text))
    c.set_prior(scene.prior)
    assert c.prior.principal_point == pytest.approx((w / 2, (20 + h - 60) / 2), abs=3)
    assert c.fitted.principal_point is None
    # ... and the dock says so, once (Processing did; a re-check trial looked for it in the dock)
    assert sum("Principal point at the picture's centre" in text for text in said) == 1
    c.set_prior(scene.prior.with_parameters(heading=scene.prior.heading + 1.0))
    assert sum("Principal point at the picture's centre" in text for text in said) == 1


def test_rough_camera_drawn_by_press_and_drag(dock, scene, qtbot):
    dock.photoFile.setFilePath(scene.photo_path)
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    canvas = dock.map_canvas
    canvas.resize(600, 600)
    canvas.setExtent(QgsProject.instance().mapLayersByName("synthetic DEM")[0].extent())
    canvas.refresh()
    dock.fovSpin.setValue(55.0)
    qtbot.mouseClick(dock.drawCameraButton, Qt.MouseButton.LeftButton)
    assert canvas.mapTool() is dock.camera_tool
    x, y = scene.camera.position[:2]
    start = canvas.getCoordinateTransform().transform(QgsPointXY(x, y))
    end = canvas.getCoordinateTransform().transform(QgsPointXY(x + 2000.0, y + 2000.0))  # north-east
    p0, p1 = QPoint(round(start.x()), round(start.y())), QPoint(round(end.x()), round(end.y()))
    qtbot.mousePress(canvas.viewport(), Qt.MouseButton.LeftButton, pos=p0)
    qtbot.mouseMove(canvas.viewport(), pos=p1)
    qtbot.mouseRelease(canvas.viewport(), Qt.MouseButton.LeftButton, pos=p1)
    prior = dock.controller.prior
    assert prior is not None
    assert abs(prior.heading - 45.0) < 2.0 and prior.fov == 55.0
    assert math.dist(prior.position[:2], (x, y)) < 2 * canvas.mapUnitsPerPixel()
    ground = scene.dem.sample(*prior.position[:2])
    assert abs(prior.position[2] - (ground + dock.heightSpin.value())) < 1e-6
    assert not dock.drawCameraButton.isChecked()
    # while dragging, the wedge follows the mouse (out to the far DEM corner, in metres)
    dock.camera_tool.dragging.emit(x, y, 90.0)
    box = dock.map_view.prior_band.band.asGeometry().boundingBox()
    assert box.xMinimum() == pytest.approx(x, abs=1.0) and box.width() > 2000.0


def test_map_cursor_says_hidden_behind_terrain(dock, scene, qtbot):
    c = dock.controller
    dock.photoFile.setFilePath(scene.photo_path)
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    c.set_fitted(scene.camera)  # the true camera, as if fitted
    # a DEM cell in the field of view that the camera does not see: behind a ridge
    from monoplot_plugin.core.xyz import compute_xyz_full

    res = compute_xyz_full(scene.camera, scene.dem, visibility=True)
    rows, cols = np.nonzero(~res.visible)
    found = None
    for r, col in zip(rows[::7], cols[::7]):
        x, y = scene.dem.cell_to_map(col + 0.5, r + 0.5)
        uv, where = c.pixel_of_ground(float(x), float(y))
        if where == "hidden":
            found = (float(x), float(y), uv)
            break
    assert found is not None
    x, y, uv = found
    dock._map_cursor(dock.map_mapping.to_canvas(x, y))
    assert dock.photo_view.cursor.isVisible()
    # and a visible cell maps back onto the pixel that sees it
    ground = c.ground_at_pixel(240.5, 250.5)
    uv2, where2 = c.pixel_of_ground(ground[0], ground[1])
    assert where2 == "visible" and math.dist(uv2, (240.5, 250.5)) < 3.0


def _jpeg_at_camera(scene, path, xmp: str = "", **tags) -> str:
    """The scene's photo as a JPEG whose GPS tags give the scene camera's position, plus ``tags`` (EXIF names
    without the prefix) and an XMP packet (in an APP1 segment, as a drone writes it)."""
    import struct

    from osgeo import gdal, osr

    src = osr.SpatialReference()
    src.ImportFromWkt(scene.dem.crs_wkt)
    dst = osr.SpatialReference()
    dst.ImportFromEPSG(4326)
    for srs in (src, dst):
        srs.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    lon, lat, _ = osr.CoordinateTransformation(src, dst).TransformPoint(*scene.camera.position[:2])

    def dms(value):
        d = int(value)
        m = int((value - d) * 60)
        return f"({d}) ({m}) ({(value - d - m / 60) * 3600:.4f})"

    photo = gdal.Open(scene.photo_path)
    mem = gdal.GetDriverByName("MEM").CreateCopy("", photo)
    mem.SetMetadata({"EXIF_GPSLatitude": dms(lat), "EXIF_GPSLatitudeRef": "N", "EXIF_GPSLongitude": dms(lon),
                     "EXIF_GPSLongitudeRef": "E", **{"EXIF_" + k: v for k, v in tags.items()}})
    gdal.GetDriverByName("JPEG").CreateCopy(str(path), mem)
    if xmp:
        data = open(path, "rb").read()
        payload = b"http://ns.adobe.com/xap/1.0/\x00" + xmp.encode("utf-8")
        with open(path, "wb") as fh:
            fh.write(data[:2] + b"\xff\xe1" + struct.pack(">H", len(payload) + 2) + payload + data[2:])
    return str(path)


def test_rough_camera_from_exif_gps(dock, scene, tmp_path):
    path = _jpeg_at_camera(scene, tmp_path / "phone.jpg", GPSAltitude=f"({scene.camera.position[2]:.1f})",
                           GPSImgDirection="(10.0)", GPSImgDirectionRef="M", FocalLengthIn35mmFilm="31")
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    said = []
    dock.controller.message.connect(lambda text, level: said.append(text))
    dock.photoFile.setFilePath(path)  # photo + DEM + GPS tags: the rough camera appears by itself
    prior = dock.controller.prior
    # the GPS height is said, and how rough it is (a trial's phone put a hand-held camera 11 m above the ground)
    assert any("GPS altitude puts it" in text and "often 10-30 m off" in text for text in said), said
    # 300 m up: the flight height, not "1.7 m held in the hand" (a trial's drone); a compass direction is said
    assert any("flight height" in text and "held in the hand" not in text for text in said), said
    assert any("magnetic north" in text for text in said), said
    # on a slope, the ground around the GPS fix is said too (a phone trial's "31 m above the DEM" at a fix 22 m
    # downslope of where it stood, 12.6 m above that ground)
    from monoplot_plugin.gui.priors import _ground_range

    low, high = _ground_range(scene.dem, *scene.camera.position[:2], 30.0)
    assert any("The ground within 30 m of the GPS position" in text for text in said) == (high - low > 10.0), said
    # the pitch from the terrain is said in the EXIF camera's own message (its own was replaced at once, a trial)
    assert any(text.startswith("Rough camera from the photo's EXIF GPS tags. Pitch set to") for text in said), said
    c = dock.controller
    assert c.state.settings["prior_source"] == "exif-gps"
    c.set_prior(prior.with_parameters(z=prior.position[2] + 5.0))  # a height edited: still the GPS position
    assert c.state.settings["prior_source"] == "exif-gps"
    uncertain = {"status": "uncertain", "rmse_px": 5.0, "n_photo": 30, "moved_m": 369.0, "position_sigma_m": 30.0,
                 "moved_from_gps": True}
    assert "moved the camera 369 m from the photo's GPS position, which is usually within 30 m" in \
        c.fit_summary(uncertain)[0]
    # an "ok" 117 m behind the GPS position (a trial's phone photo, distant terrain trading the position for the
    # field of view) is doubted; check points, or a σ nobody stated, leave the verdict to the fit
    ok = dict(uncertain, status="ok", moved_m=117.0, position_sigma_stated=True, message="paired fit.")
    c.doubt_a_moved_camera(ok)
    assert ok["status"] == "uncertain" and "117 m from the photo's GPS position" in ok["message"]
    for kept in (dict(ok, status="ok", n_check=5), dict(ok, status="ok", position_sigma_stated=False),
                 dict(ok, status="ok", moved_m=80.0)):
        c.doubt_a_moved_camera(kept)
        assert kept["status"] == "ok"
    # the GPS position typed again, to the metre (a flood trial): still the GPS's, so still known within 30 m
    c.set_prior(prior.with_parameters(x=round(prior.position[0]) + 0.5, y=round(prior.position[1]) - 0.5))
    assert c.state.settings["prior_source"] == "exif-gps"
    c.set_prior(prior.with_parameters(x=prior.position[0] + 50.0))  # moved: no longer the GPS position
    assert "prior_source" not in c.state.settings
    assert prior is not None
    assert math.dist(prior.position[:2], scene.camera.position[:2]) < 1.0
    assert abs(prior.position[2] - scene.camera.position[2]) < 0.2
    assert abs(prior.fov - 60.2) < 0.5  # 2 atan(18 / 31)
    assert 8.0 < prior.heading < 12.0  # true north -> grid north: within a couple of degrees in Switzerland


def test_a_drone_photo_gets_its_gimbals_pitch_and_heading(dock, scene, tmp_path):
    """A drone looks down at -40 to -90 degrees and its EXIF has no direction of view; its XMP (DJI) has the
    gimbal's angles. Without them the rough camera looked level at the DEM's centre."""
    xmp = ('<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#">'
           '<rdf:Description rdf:about="" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" '
           'drone-dji:RelativeAltitude="+118.40" drone-dji:GimbalYawDegree="-20.50" '
           'drone-dji:GimbalPitchDegree="-47.80"/></rdf:RDF></x:xmpmeta>')
    path = _jpeg_at_camera(scene, tmp_path / "DJI_0007.JPG", xmp, FocalLengthIn35mmFilm="24",
                           GPSAltitude=f"({scene.camera.position[2] + 100.0:.1f})")
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    said = []
    dock.controller.message.connect(lambda text, level: said.append(text))
    dock.photoFile.setFilePath(path)
    prior = dock.controller.prior
    assert prior.pitch == pytest.approx(-47.8) and dock.pitchSpin.value() == pytest.approx(-47.8, abs=0.05)
    # the gimbal's yaw is from true north; the DEM's grid north differs by the meridian convergence (< 2 deg here)
    assert abs((prior.heading - 339.5 + 180.0) % 360.0 - 180.0) < 2.0
    text = next(t for t in said if t.startswith("Rough camera from the photo's EXIF GPS tags."))
    said_heading = f"Pitch -47.8° and heading {prior.heading % 360.0:.0f}° from the drone's gimbal (XMP tags)."
    assert said_heading in text and "Pitch set to" not in text  # the heading the box shows: from grid north
    assert "The drone logged 118 m above its take-off point." in text and "No direction in EXIF" not in text
    # looking down, the view wedge ends near where the picture's top edge meets the ground, not across the DEM
    box = dock.map_view.prior_band.band.asGeometry().boundingBox()
    assert max(box.width(), box.height()) < 0.4 * dock.map_view.reach(*prior.position[:2])


def test_typing_a_photo_path_loads_it_once_complete(dock, scene, qtbot, qgis_iface):
    qgis_iface.messageBar().clear_messages()
    edit = dock.photoFile.lineEdit()
    edit.clear()
    qtbot.keyClicks(edit, scene.photo_path)  # every keystroke changes the path
    assert dock.controller.state.photo_path == scene.photo_path and dock.controller.image is not None
    assert not qgis_iface.messageBar().get_messages(Qgis.MessageLevel.Critical)  # no error for partial paths


def test_large_photo_paints_from_a_reduced_copy_when_zoomed_out(dock, tmp_path):
    big = QImage(6000, 4000, QImage.Format.Format_RGB888)
    big.fill(QColor(90, 120, 160))
    path = str(tmp_path / "big.jpg")
    assert big.save(path)
    dock.photoFile.setFilePath(path)
    item = dock.photo_canvas.photo_item
    assert dock.controller.photo_size == (6000, 4000)
    assert item.level_for(400).width() < 1500  # whole photo in a small view: a small level
    assert item.level_for(5000).width() == 6000  # zoomed in: full resolution


def test_main_map_in_another_crs(dock, scene, qtbot):
    """The map canvas in degrees while the DEM is in metres: clicks and markers are transformed both ways."""
    from qgis.core import QgsCoordinateReferenceSystem, QgsCoordinateTransform

    from monoplot_plugin.state import MAP, Point, add_points

    dock.photoFile.setFilePath(scene.photo_path)
    layer = QgsProject.instance().mapLayersByName("synthetic DEM")[0]
    dock.demCombo.setLayer(layer)
    canvas = dock.map_canvas
    wgs84 = QgsCoordinateReferenceSystem("EPSG:4326")
    canvas.setDestinationCrs(wgs84)
    to_wgs = QgsCoordinateTransform(layer.crs(), wgs84, QgsProject.instance())
    canvas.setExtent(to_wgs.transformBoundingBox(layer.extent()))
    canvas.refresh()
    x, y = scene.camera.position[:2]
    # a DEM point is drawn where the map shows that place
    c = dock.controller
    p = Point.new(MAP, x, y + 2000.0, 1500.0)
    c.stack.push(add_points(c.state, [p]))
    c.select(MAP, p.id)
    shown = dock.map_view.markers.highlight.center()
    expected = to_wgs.transform(QgsPointXY(x, y + 2000.0))
    assert abs(shown.x() - expected.x()) < 1e-6 and abs(shown.y() - expected.y()) < 1e-6
    # and a click there finds it again (tolerance converted to metres)
    screen = canvas.getCoordinateTransform().transform(expected)
    qtbot.mouseClick(dock.drawCameraButton, Qt.MouseButton.LeftButton)
    dock.mapToolButton.setChecked(True)
    qtbot.mouseClick(canvas.viewport(), Qt.MouseButton.RightButton, pos=QPoint(round(screen.x()), round(screen.y())))
    assert c.state.points[p.id].status == "rejected"
    c.stack.undo()  # shown again
    # the map's CRS changed with the point on show: its marker follows it (a trial: the markers stayed at the old
    # canvas coordinates, 5,000 km off, while the camera was redrawn)
    mercator = QgsCoordinateReferenceSystem("EPSG:3857")
    canvas.setDestinationCrs(mercator)
    drawn = [pt for band in dock.map_view.markers.bands.values() for pt in band.asGeometry().asMultiPoint()]
    expected = QgsCoordinateTransform(layer.crs(), mercator, QgsProject.instance()).transform(
        QgsPointXY(x, y + 2000.0))
    assert len(drawn) == 1 and drawn[0].distance(expected) < 1e-3, (drawn, expected)


def test_typing_a_field_of_view_moves_the_rough_camera_once_on_enter(dock, scene, qtbot):
    """Typing "55" in Field of view: the camera is not moved to 5 deg on the way (that warned it did not look at the
    DEM), but to 55 deg on Enter."""
    dock.photoFile.setFilePath(scene.photo_path)
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    c = dock.controller
    c.set_prior(scene.prior)
    fovs, messages = [], []
    c.cameraChanged.connect(lambda: fovs.append(c.prior.fov if c.prior is not None else None))
    c.message.connect(lambda text, *_: messages.append(text))
    spin = dock.fovSpin
    spin.setFocus()
    spin.selectAll()
    qtbot.keyClicks(spin, "55")
    assert c.prior.fov == scene.prior.fov  # nothing yet
    qtbot.keyClick(spin, Qt.Key.Key_Return)
    assert c.prior.fov == 55.0 and 5.0 not in fovs
    assert not any("does not look at the DEM" in m for m in messages)


def test_an_rgb_image_chosen_as_the_dem_is_a_warning(dock, scene, tmp_path):
    """A trial chose a 3-band byte GeoTIFF (an orthophoto) as the DEM: Suggest ran on grey values as heights and
    nothing was said. Now a warning says it looks like an image (its first band is still used)."""
    from osgeo import gdal, osr

    path = str(tmp_path / "ortho_rgb.tif")
    ds = gdal.GetDriverByName("GTiff").Create(path, 64, 48, 3, gdal.GDT_Byte)
    ds.SetGeoTransform((600000.0, 10.0, 0.0, 5100000.0, 0.0, -10.0))
    srs = osr.SpatialReference()
    srs.ImportFromEPSG(32632)
    ds.SetProjection(srs.ExportToWkt())
    for band in range(1, 4):
        ds.GetRasterBand(band).WriteArray(np.random.default_rng(band).integers(0, 255, (48, 64)).astype(np.uint8))
    ds = None
    layer = QgsRasterLayer(path, "ortho_rgb")
    QgsProject.instance().addMapLayer(layer)
    messages = []
    dock.controller.message.connect(lambda text, level: messages.append((text, level)))
    dock.controller.set_dem_layer(layer)
    warned = [t for t, level in messages if "looks like an image" in t and level == Qgis.MessageLevel.Warning]
    assert warned, messages
    # a real DEM says nothing of the kind
    messages.clear()
    dock.controller.set_dem_layer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    assert not any("looks like an image" in t for t, _ in messages)


def test_a_dem_in_another_crs_with_map_work_on_it_is_a_warning(dock, scene, tmp_path):
    """A trial fitted on an LV03 DEM, then chose one in degrees (used in UTM): the map points and cameras kept their
    numbers in the new frame, vanished from the map, and nothing was said."""
    from osgeo import gdal

    from monoplot_plugin.state import MAP, Point, add_points

    dock.photoFile.setFilePath(scene.photo_path)
    layer = QgsProject.instance().mapLayersByName("synthetic DEM")[0]
    dock.demCombo.setLayer(layer)
    c = dock.controller
    x, y = scene.camera.position[:2]
    c.stack.push(add_points(c.state, [Point.new(MAP, x, y + 2000.0, 1500.0)]))
    other = str(tmp_path / "dem_3857.tif")
    gdal.Warp(other, layer.source(), dstSRS="EPSG:3857")
    moved = QgsRasterLayer(other, "DEM in another CRS")
    QgsProject.instance().addMapLayer(moved)
    messages = []
    c.message.connect(lambda text, level: messages.append((text, level)))
    assert c.set_dem_layer(moved)
    assert any("not converted" in t and level == Qgis.MessageLevel.Warning for t, level in messages), messages
    messages.clear()
    assert c.set_dem_layer(layer)  # back to the CRS the points are in: nothing to say
    assert not any("not converted" in t for t, _ in messages)


def test_a_layer_refused_as_the_dem_leaves_the_box_on_the_dem_in_use(dock, scene, tmp_path):
    """A trial chose the photo (a raster without CRS) as the DEM: refused, but the box went on showing it while the
    previous DEM was used."""
    dem_layer = QgsProject.instance().mapLayersByName("synthetic DEM")[0]
    dock.demCombo.setLayer(dem_layer)
    assert dock.controller.dem_layer is dem_layer
    photo = QgsRasterLayer(scene.photo_path, "photo as raster")
    assert photo.isValid()
    QgsProject.instance().addMapLayer(photo)
    dock.demCombo.setLayer(photo)  # as the person picks it in the box
    assert dock.controller.dem_layer is dem_layer  # refused
    assert dock.demCombo.currentLayer() is dem_layer


def test_a_new_photo_with_gps_tags_gets_its_own_rough_camera_not_the_last_ones(dock, scene, tmp_path):
    """A trial chose its phone photos one after another: the second kept the first one's GPS camera (taken
    elsewhere) and it was saved as the second one's prior. A new photo's own GPS tags win; a photo without any
    (the next frame of the same view) keeps the camera carried to it."""
    import shutil

    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    c = dock.controller
    first = _jpeg_at_camera(scene, tmp_path / "first.jpg", GPSAltitude=f"({scene.camera.position[2]:.1f})",
                            GPSImgDirection="(10.0)", GPSImgDirectionRef="T")
    dock.photoFile.setFilePath(first)
    gps_prior = c.prior
    assert gps_prior is not None and c.state.settings["prior_source"] == "exif-gps"
    elsewhere = gps_prior.with_parameters(x=gps_prior.position[0] + 400.0, heading=gps_prior.heading + 40.0)
    c.set_prior(elsewhere)  # the first photo's camera, moved by hand: not this second photo's
    second = _jpeg_at_camera(scene, tmp_path / "second.jpg", GPSAltitude=f"({scene.camera.position[2]:.1f})",
                             GPSImgDirection="(10.0)", GPSImgDirectionRef="T")
    said = []
    c.message.connect(lambda text, level: said.append(text))
    dock.photoFile.setFilePath(second)
    assert not any("previous photo" in text or "another resolution" in text for text in said), said
    assert np.allclose(c.prior.position[:2], gps_prior.position[:2], atol=1.0)
    assert abs(c.prior.heading - gps_prior.heading) < 0.1
    c.set_prior(elsewhere)
    plain = tmp_path / "third.png"
    shutil.copy(scene.photo_path, plain)  # no tags: the carried camera stays
    dock.photoFile.setFilePath(str(plain))
    assert np.allclose(c.prior.position, elsewhere.position) and abs(c.prior.heading - elsewhere.heading) < 1e-6
    # ... and said to be the previous photo's, not "the same picture at another resolution" (a trial)
    assert any(text.startswith("The rough camera of the previous photo is kept for this one") for text in said)
    # a photo with a lens in EXIF but no GPS: the carried camera takes its field of view
    from osgeo import gdal

    mem = gdal.GetDriverByName("MEM").CreateCopy("", gdal.Open(scene.photo_path))
    mem.SetMetadata({"EXIF_FocalLengthIn35mmFilm": "20"})
    gdal.GetDriverByName("JPEG").CreateCopy(str(tmp_path / "wide.jpg"), mem)
    said.clear()
    dock.photoFile.setFilePath(str(tmp_path / "wide.jpg"))
    lens = c.exif_fov()
    assert lens is not None and abs(lens - elsewhere.fov) > 5.0
    assert abs(c.prior.fov - lens) < 0.01 and np.allclose(c.prior.position, elsewhere.position)
    assert any("Its field of view is this photo's, from EXIF" in text for text in said), said


def test_find_camera_searches_every_direction_when_the_heading_is_a_guess(dock, scene, tmp_path, qtbot):
    """Trials B and C: EXIF with a position but no direction gives a heading aimed at the DEM's centre, and the
    ordinary registration searched a few degrees around it. Find camera then searches every direction, and says so
    before it runs, until a heading is given."""
    path = _jpeg_at_camera(scene, tmp_path / "nodir.jpg", GPSAltitude=f"({scene.camera.position[2]:.1f})")
    dock.demCombo.setLayer(QgsProject.instance().mapLayersByName("synthetic DEM")[0])
    c = dock.controller
    said = []
    c.message.connect(lambda text, level: said.append(text))
    dock.photoFile.setFilePath(path)
    assert c.state.settings.get("prior_heading_guessed") and c.prior is not None
    # said when the rough camera is made, before any click (a re-check trial saw it only after clicking)
    assert any("Find camera automatically searches every direction" in text for text in said), said
    assert dock.auto_panel.run()
    c.cancel()
    qtbot.waitUntil(lambda: not c.busy, timeout=60000)
    assert any(text.startswith("The photo's EXIF has no direction of view: every direction is searched")
               for text in said), said
    c.set_prior(c.prior.with_parameters(pitch=c.prior.pitch - 1.0))  # a pitch edited: still a guessed heading
    assert c.state.settings.get("prior_heading_guessed")
    c.set_prior(c.prior.with_parameters(heading=c.prior.heading + 20.0))  # the view drawn: no longer a guess
    assert not c.state.settings.get("prior_heading_guessed")
    said.clear()
    assert dock.auto_panel.run()
    c.cancel()
    qtbot.waitUntil(lambda: not c.busy, timeout=60000)
    assert not any("every direction is searched" in text for text in said), said


def test_the_ground_around_a_gps_fix():
    from monoplot_plugin.core.dem import Dem
    from monoplot_plugin.gui.priors import _ground_range

    slope = Dem.from_array(np.add.outer(np.zeros(50), np.arange(50.0)) * 10.0, (0.0, 10.0, 0.0, 500.0, 0.0, -10.0))
    low, high = _ground_range(slope, 250.0, 250.0, 30.0)  # 1 m a metre eastward: 30 m either way
    assert (low, high) == (pytest.approx(215.0, abs=0.5), pytest.approx(275.0, abs=0.5))
    assert all(math.isnan(v) for v in _ground_range(slope, 5000.0, 5000.0, 30.0))
