"""One-page report: PNG and PDF, parameters with sigma, refusal to overwrite."""

import numpy as np
import pytest
from osgeo import gdal

from monoplot_plugin.outputs import OutputExistsError
from monoplot_plugin.outputs.report import ReportPoints, parameter_sigmas, write_report
from monoplot_plugin.workflow.products import report_points


def scene_points(scene, n=12, noise_px=1.5, seed=3):
    """Paired points on the plane scene: true ground points, photo positions with pixel noise."""
    rng = np.random.default_rng(seed)
    ground = np.argwhere(np.isfinite(scene.xyz[..., 2]))
    pick = ground[rng.choice(len(ground), n, replace=False)]
    xyz = scene.xyz[pick[:, 0], pick[:, 1]]
    uv = pick[:, ::-1] + 0.5 + rng.normal(0, noise_px, (n, 2))
    return ReportPoints(uv, xyz)


def test_report_png_and_pdf(plane_scene, tmp_path):
    scene = plane_scene
    points = scene_points(scene)
    csv = tmp_path / "points.csv"
    csv.write_text("u_px,v_px,X,Y,Z\n" + "\n".join(
        ",".join(f"{v:.3f}" for v in (*uv, *p)) for uv, p in zip(points.uv, points.xyz)), encoding="utf-8")
    assert np.allclose(report_points(csv, scene.dem).xyz, points.xyz, atol=1e-3)
    png = write_report(tmp_path / "rapport été.png", scene.photo, scene.camera, scene.dem,
                       report_points(csv, scene.dem), xyz=scene.xyz,
                       title="Plane test")
    ds = gdal.Open(str(png))
    assert ds.GetDriver().ShortName == "PNG"
    assert ds.RasterXSize < ds.RasterYSize  # A4 portrait
    assert ds.RasterXSize > 1000
    pixels = ds.ReadAsArray()
    assert pixels.std() > 10  # not blank
    pdf = write_report(tmp_path / "report.pdf", scene.photo, scene.camera, scene.dem, points=points,
                       xyz=scene.xyz)
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF") and data.count(b"/Type /Page\n") + data.count(b"/Type /Page ") <= 2
    with pytest.raises(OutputExistsError):
        write_report(pdf, scene.photo, scene.camera, scene.dem, points=points, xyz=scene.xyz)
    assert pdf.read_bytes() == data


def test_parameter_sigmas_grow_with_noise(plane_scene):
    scene = plane_scene
    quiet = parameter_sigmas(scene.camera, scene_points(scene, noise_px=0.5))
    noisy = parameter_sigmas(scene.camera, scene_points(scene, noise_px=5.0))
    assert set(quiet) == {"x", "y", "z", "heading", "pitch", "roll", "fov"}
    assert all(np.isfinite(v) and v > 0 for v in quiet.values())
    assert noisy["heading"] > quiet["heading"] and noisy["z"] > quiet["z"]
    few = parameter_sigmas(scene.camera, scene_points(scene, n=3))
    assert all(np.isnan(v) for v in few.values())  # 6 residuals, 7 unknowns: no covariance


def test_report_heading_is_the_azimuth_the_dock_shows(plane_scene, tmp_path):
    """A fit may return heading -63.6; the dock shows 296.4 (clockwise from grid north) and so must the report."""
    from monoplot_plugin.outputs.report import parameter_lines

    camera = plane_scene.camera.with_parameters(heading=-63.6349)
    lines = parameter_lines(camera.with_parameters(x=650130.0912), {"heading": 0.294, "x": 627.3, "pitch": 2.94})
    by_name = {line.split()[0]: line for line in lines[2:]}
    assert "296.37 ± 0.29 °" in by_name["heading"], by_name["heading"]
    # no more digits than the σ allows (a trial read "x 650130.09 ± 627 m", "heading 296.4389 ± 2.94°")
    assert "650130 ± 627 m" in by_name["x"] and " ± 2.9 °" in by_name["pitch"], lines
    # an uncertain fit's ± are starred and said to assume its pairs right, as the dock says (a trial's report
    # printed "heading 245.71 ± 0.51°" plainly for a camera 15° off)
    doubted = parameter_lines(camera, {"heading": 0.294}, "uncertain")
    assert any("296.37 ± 0.29* °" in line for line in doubted), doubted
    assert "may be off by far more" in doubted[-1] and "this uncertain camera" in doubted[-1]
    assert not any("*" in line for line in lines)
    assert write_report(tmp_path / "r.png", plane_scene.photo, camera, plane_scene.dem).exists()


def test_a_long_fit_status_is_cut_to_the_page(plane_scene):
    """An automatic registration's verdict of a dozen sentences ran off the bottom of the page: the block of text
    keeps to the lines the page holds and says it was cut; a short one is printed whole."""
    from matplotlib.figure import Figure

    from monoplot_plugin.outputs.report import CUT_NOTE, REPORT_TEXT_LINES, _draw_parameters

    scene = plane_scene
    points = scene_points(scene)
    for verdict, cut in (("uncertain: " + "The residuals measure how well the automatic pairs agree. " * 40, True),
                         ("ok: paired fit on 12 pairs.", False)):
        ax = Figure().add_subplot()
        _draw_parameters(ax, scene.camera, None, 1.0, points, scene.xyz, verdict)
        text = ax.texts[0].get_text()
        assert len(text.splitlines()) <= REPORT_TEXT_LINES
        assert text.endswith(CUT_NOTE) == cut and "Fit status" in text


def test_the_report_names_the_points_with_the_largest_residuals(plane_scene):
    """A trial could not tell from the report's arrows which GCP had the 13.3 px residual: the text names the
    largest, by the names printed on the photo."""
    from matplotlib.figure import Figure

    from monoplot_plugin.outputs.report import ReportPoints, _draw_parameters

    scene = plane_scene
    base = scene_points(scene, noise_px=0.2)
    uv = base.uv.copy()
    uv[4] += (9.0, 0.0)  # one point picked 9 px off
    points = ReportPoints(uv, base.xyz, [f"G{i}" for i in range(len(uv))])
    ax = Figure().add_subplot()
    _draw_parameters(ax, scene.camera, None, 2.7, points, scene.xyz, "ok: paired fit on 12 pairs.")
    line = next(t for t in ax.texts[0].get_text().splitlines() if t.startswith("Largest residuals"))
    assert line.startswith("Largest residuals: G4 (9.") and line.count(" px)") == 5, line


def test_the_status_leads_the_badge_and_the_reason_survives_the_cut(plane_scene):
    """A trial's report showed "RMSE 2.43 px" alone in the badge, and the reason of an "uncertain" verdict was cut
    off at the bottom of the page: the badge now starts with the status, in its colour, and the text with why."""
    from matplotlib.colors import to_hex
    from matplotlib.figure import Figure

    from monoplot_plugin.outputs.report import STATUS_COLOURS, _draw_parameters, _draw_points

    scene = plane_scene
    points = scene_points(scene)
    residual = scene.camera.project(points.xyz) - points.uv
    ax = Figure().add_subplot()
    _draw_points(ax, scene.photo, points, residual, 2.43, "uncertain")
    badge = next(t for t in ax.texts if "RMSE" in t.get_text())
    assert badge.get_text() == "uncertain · RMSE 2.43 px"
    # with check points, their error leads, as in the dock (a trial's badge gave the fit's 5.25 px, the check
    # points were 17.2 px off)
    ax = Figure().add_subplot()
    _draw_points(ax, scene.photo, points, residual, 2.43, "uncertain", check_rmse=17.2)
    assert next(t for t in ax.texts if "RMSE" in t.get_text()).get_text() == \
        "uncertain · check points 17.20 px · fit RMSE 2.43 px"
    assert to_hex(badge.get_bbox_patch().get_facecolor()) == STATUS_COLOURS["uncertain"]
    verdict = ("uncertain: unpaired fit: 287 of 462 photo points matched. " + "The residuals measure agreement. " * 40
               + "Uncertain: the camera stands 36 m under the terrain.")
    ax = Figure().add_subplot()
    _draw_parameters(ax, scene.camera, None, 1.0, points, scene.xyz, verdict)
    text = ax.texts[0].get_text()
    assert "(cut to fit the page" in text and "36 m under the terrain" in text


def test_check_points_are_drawn_and_measured_first(plane_scene, tmp_path):
    """A table with a check column: the check rows are drawn apart and their RMSE is the first line after the
    parameters (the measured accuracy), the fitted rows keep the fit's RMSE."""
    from matplotlib.figure import Figure

    from monoplot_plugin.outputs.report import _checks_rmse, _draw_checks, _draw_parameters

    scene = plane_scene
    points = scene_points(scene, n=12, noise_px=0.0)
    csv = tmp_path / "gcps.csv"
    from monoplot_plugin.workflow.points_csv import write_points_csv as write_csv

    uv = points.uv.copy()
    uv[8:] += [6.0, 8.0]  # the four check points 10 px off
    write_csv(str(csv), uv=uv, xyz=points.xyz, check=[False] * 8 + [True] * 4, ids=[f"P{i:02d}" for i in range(12)])
    fitted, checks = report_points(csv, scene.dem, split_checks=True)
    assert len(fitted.uv) == 8 and len(checks.uv) == 4
    ax = Figure().add_subplot()
    _draw_checks(ax, scene.camera, checks)
    # named by the table's ids, as the control points are (a re-check trial's check points had no names)
    assert sorted(t.get_text() for t in ax.texts) == ["P08", "P09", "P10", "P11"]
    # numbers of a GCP table are said as check points' (a trial read two "3"s: a control point's and a check's)
    from monoplot_plugin.outputs.report import ReportPoints

    numbered = Figure().add_subplot()
    _draw_checks(numbered, scene.camera, ReportPoints(checks.uv, checks.xyz, ["3", "4", "5", "6"]))
    assert sorted(t.get_text() for t in numbered.texts) == ["C3", "C4", "C5", "C6"]
    rmse = _checks_rmse(scene.camera, checks)
    assert rmse == pytest.approx(10.0, abs=0.2)
    # a GCP table in longitude/latitude, as fitcamera reads it: a trial's report said "RMSE nan px", no checks
    from osgeo import osr

    source, wgs84 = osr.SpatialReference(), osr.SpatialReference()
    source.SetFromUserInput(scene.dem.crs_wkt)
    wgs84.SetFromUserInput("EPSG:4326")
    wgs84.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    source.SetAxisMappingStrategy(osr.OAMS_TRADITIONAL_GIS_ORDER)
    to_lonlat = osr.CoordinateTransformation(source, wgs84)
    lonlat = np.array([to_lonlat.TransformPoint(*p) for p in points.xyz])
    write_csv(str(csv), uv=uv, xyz=lonlat, check=[False] * 8 + [True] * 4, ids=[f"P{i:02d}" for i in range(12)])
    fitted_ll, checks_ll = report_points(csv, scene.dem, split_checks=True)
    assert np.allclose(checks_ll.xyz, checks.xyz, atol=0.05) and np.allclose(fitted_ll.xyz, fitted.xyz, atol=0.05)
    assert _checks_rmse(scene.camera, checks_ll) == pytest.approx(rmse, abs=0.01)
    text_ax = Figure().add_subplot()
    _draw_parameters(text_ax, scene.camera, None, 0.1, fitted, scene.xyz, "", rmse, checks)
    assert "Check points (magenta, kept out of the fit): RMSE 10.00 px on 4" in text_ax.texts[0].get_text()
    png = write_report(tmp_path / "r.png", scene.photo, scene.camera, scene.dem, fitted, xyz=scene.xyz,
                       checks=checks)
    assert gdal.Open(str(png)).RasterXSize > 1000


def test_the_report_says_what_the_camera_is_worth_on_the_ground(plane_scene):
    """A desktop trial: no report gave an accuracy in metres. The check points' error (else the paired points'
    residuals, said to be that) carried to the terrain seen is a line of the page; no points, no such line, and
    no "Control points" legend over a photo that has none."""
    from matplotlib.figure import Figure

    from monoplot_plugin.core.fit import check_bound_px
    from monoplot_plugin.outputs.report import _draw_parameters, _draw_points
    from monoplot_plugin.workflow.products import ground_error, leave_one_out_px, metres_words, points_accuracy

    scene = plane_scene
    points, checks = scene_points(scene, seed=3), scene_points(scene, n=5, noise_px=4.0, seed=4)
    text = points_accuracy(scene.camera, scene.dem, scene.xyz, points, checks)
    check_rmse = float(np.sqrt(np.mean(np.sum((scene.camera.project(checks.xyz) - checks.uv) ** 2, axis=1))))
    # what 5 check points vouch for: their RMSE raised for so few (1.59 times), carried to the ground
    bound = check_bound_px(check_rmse, 5)
    assert bound == pytest.approx(1.593 * check_rmse, rel=0.001)
    metres = ground_error(scene.camera, scene.xyz, bound, scene.dem)[1]
    assert text.startswith(f"check points {check_rmse:.1f} px on 5, at most {bound:.1f} px at 95 %: about "
                           f"{metres_words(metres)} on the ground")
    # without check points: the larger of the paired points' residuals and their leave-one-out error, both said
    paired = points_accuracy(scene.camera, scene.dem, scene.xyz, points)
    loo = leave_one_out_px(scene.camera, points.uv, points.xyz)
    rmse = float(np.sqrt(np.mean(np.sum((scene.camera.project(points.xyz) - points.uv) ** 2, axis=1))))
    assert np.isfinite(loo) and loo > rmse
    assert paired.startswith(f"no check points; {len(points.uv)} paired points, RMSE {rmse:.1f} px, "
                             f"leave-one-out {loo:.1f} px: about "
                             f"{metres_words(ground_error(scene.camera, scene.xyz, loo, scene.dem)[1])} on the ground")
    assert points_accuracy(scene.camera, scene.dem, scene.xyz) == ""
    # check points closer than the paired points' leave-one-out error: the larger of the two measures is said
    close = scene_points(scene, n=3, noise_px=0.2, seed=5)
    larger = points_accuracy(scene.camera, scene.dem, scene.xyz, points, close)
    assert larger.startswith(f"{len(points.uv)} paired points, RMSE {rmse:.1f} px, leave-one-out {loo:.1f} px, "
                             "more than the check points ") and " px on 3, at most " in larger
    ax = Figure().add_subplot()
    _draw_parameters(ax, scene.camera, None, 1.0, points, scene.xyz, "ok: paired fit.", accuracy=text)
    assert "Ground accuracy: check points" in ax.texts[0].get_text()
    # a print's share of ground is of its picture, not of the scan with its paper
    picture = np.zeros(scene.xyz.shape[:2], bool)
    picture[: picture.shape[0] // 2] = True
    ax = Figure().add_subplot()
    _draw_parameters(ax, scene.camera, None, 1.0, points, scene.xyz, "ok: paired fit.", picture=picture)
    share = np.isfinite(scene.xyz[..., 2])[picture].mean()
    assert f"Ground seen in {100 * share:.0f} % of the picture" in ax.texts[0].get_text()
    ax = Figure().add_subplot()
    _draw_points(ax, scene.photo, None, None, None, "")
    assert ax.get_title(loc="left") == "The photo (no control points given)"


def test_a_large_photo_and_dem_are_drawn_from_shrunk_copies_in_their_own_coordinates(plane_scene, tmp_path,
                                                                                      monkeypatch):
    """A 24 MP scan over a 25 M-cell DEM: the report drew both whole (2 GB more memory, 25 s). The page shows every
    k-th pixel and cell; the points, the axes and the figures stay in the photo's own pixels."""
    from matplotlib.figure import Figure

    from monoplot_plugin.outputs import report

    monkeypatch.setattr(report, "PAGE_PIXELS", 60)  # the 240 x 160 scene counts as large: k = 4
    scene = plane_scene
    points = scene_points(scene)
    residual = scene.camera.project(points.xyz) - points.uv
    ax = Figure().add_subplot()
    report._draw_points(ax, scene.photo[::4, ::4], points, residual, 1.5, "ok", size=(240, 160))
    assert ax.images[0].get_array().shape[:2] == (40, 60) and tuple(ax.images[0].get_extent()) == (0, 240, 160, 0)
    assert ax.get_xlim() == (0, 240) and ax.get_ylim() == (160, 0)
    path = report.write_report(tmp_path / "r.png", scene.photo, scene.camera, scene.dem, points, xyz=scene.xyz)
    assert path.stat().st_size > 10_000


def test_names_of_close_points_do_not_cover_each_other(plane_scene):
    """Five control points and two check points a few pixels apart (a re-check trial's report drew their names over
    each other): every name's box, as drawn, is clear of the others'."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from monoplot_plugin.outputs import report

    scene = plane_scene
    points = scene_points(scene, n=7, noise_px=0.0)
    uv = np.array([[120.0, 80.0], [123.0, 81.0], [118.0, 84.0], [125.0, 78.0], [121.0, 86.0], [124.0, 84.0],
                   [117.0, 79.0]])
    control = ReportPoints(uv[:5], points.xyz[:5], names=[f"GCP{i}" for i in range(5)])
    checks = ReportPoints(uv[5:], points.xyz[5:], names=["CHK1", "CHK2"])
    fig = Figure(figsize=(8.27, 4.0))
    FigureCanvasAgg(fig)
    ax = fig.add_axes((0.05, 0.05, 0.9, 0.9))
    residual = np.zeros((5, 2))
    labels = report._draw_points(ax, scene.photo, control, residual, 0.0, "ok", others=checks.uv)
    report._draw_checks(ax, scene.camera, checks, labels)
    renderer = fig.canvas.get_renderer()
    names = [t for t in ax.texts if t.get_text().startswith(("GCP", "CHK"))]
    assert len(names) == 7
    fig.canvas.draw()
    # the names' dark backings (not their leader lines), a pixel in from their edges
    boxes = [t.get_bbox_patch().get_window_extent(renderer).expanded(0.97, 0.9) for t in names]
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            assert not boxes[i].overlaps(boxes[j]), (names[i].get_text(), names[j].get_text())


def test_a_sigma_too_large_to_mean_anything_is_said_undetermined(plane_scene):
    """A poor fit's covariance gave "± 6894594°" (a flood trial): the report says the parameter is undetermined."""
    from monoplot_plugin.outputs.report import parameter_lines

    lines = parameter_lines(plane_scene.camera, {"heading": 6894594.0, "x": 1.3e9, "pitch": 0.25})
    by_name = {line.split()[0]: line for line in lines if line.split()}
    assert by_name["heading"].endswith("° (± undetermined)") and by_name["x"].endswith("m (± undetermined)")
    assert "± 0.25" in by_name["pitch"] and "±" not in by_name["roll"]


def test_crowded_point_names_give_way_and_the_largest_residuals_are_named():
    """A trial's automatic registration reported 333 points whose names lay over each other."""
    from matplotlib.figure import Figure

    from monoplot_plugin.outputs.report import ALL_LABELS_UP_TO, ReportPoints, _draw_points

    rng = np.random.default_rng(1)
    photo = np.zeros((300, 400, 3), np.uint8)

    def drawn(n):
        uv = rng.uniform([10, 10], [390, 290], size=(n, 2))
        residual = rng.normal(0, 1.0, size=(n, 2))
        residual[0] = (30.0, 0.0)  # the largest
        ax = Figure(figsize=(8, 6)).add_subplot()
        _draw_points(ax, photo, ReportPoints(uv, np.zeros((n, 3))), residual, 1.0)
        return [t.get_text() for t in ax.texts if t.get_text().isdigit()]

    few = drawn(ALL_LABELS_UP_TO)
    assert sorted(few, key=int) == [str(i + 1) for i in range(ALL_LABELS_UP_TO)]  # all named, as before
    many = drawn(333)
    assert "1" in many and 20 < len(many) < 333
