"""Every output of every algorithm under a hostile folder: full disk, a file-size limit (quota), a read-only
folder, a missing folder, a cancel just before the rename, and a replaced earlier output. Each case asserts the
message the user sees and that the earlier output survives byte for byte, with no temporary file left."""

from pathlib import Path

import pytest
from qgis.core import QgsProcessingException, QgsProcessingFeedback

from tests.badinput.conftest import file_size_limit, leftovers, snapshot
from tests.badinput.outputs_cases import OUTPUTS, copy_output, members, parameters, scene_points

CASES = sorted(OUTPUTS)


@pytest.fixture(scope="module")
def points(small_scene, tmp_path_factory):
    return scene_points(small_scene, tmp_path_factory.mktemp("points"))


@pytest.fixture(scope="module")
def golden(processing_provider, small_scene, points, tmp_path_factory):
    """One good output of every case (written by the algorithms themselves): the 'earlier output'."""
    import processing

    def run_alg(name, params):
        return processing.run(f"monoplot:{name}", params, feedback=QgsProcessingFeedback())

    base = tmp_path_factory.mktemp("golden")
    paths = {}
    for case in CASES:
        folder = base / case
        folder.mkdir()
        out = folder / OUTPUTS[case][1]
        run_alg(OUTPUTS[case][0], parameters(case, small_scene, points, out))
        assert members(out), case
        paths[case] = out
    return paths


def run_into(run_alg, case, scene, points, folder: Path, feedback=None):
    out = folder / OUTPUTS[case][1]
    return run_alg(OUTPUTS[case][0], parameters(case, scene, points, out), feedback)


@pytest.mark.parametrize("case", CASES)
def test_full_disk_keeps_the_earlier_output(case, run_alg, small_scene, points, golden, full_disk):
    with full_disk(lambda folder: copy_output(golden[case], folder)) as folder:
        before = snapshot(folder)
        with pytest.raises(QgsProcessingException, match=r"(disk is full|no space left|larger than the folder)"):
            run_into(run_alg, case, small_scene, points, folder)
        assert snapshot(folder) == before
        assert leftovers(folder) == []


@pytest.mark.parametrize("case", CASES)
def test_file_size_limit_keeps_the_earlier_output(case, run_alg, small_scene, points, golden, tmp_path):
    copy_output(golden[case], tmp_path)
    before = snapshot(tmp_path)
    limit = max(64, max(len(b) for b in before.values()) // 2)
    with pytest.raises(QgsProcessingException, match=r"cannot write .*(disk is full|larger than the folder)"):
        with file_size_limit(limit):
            run_into(run_alg, case, small_scene, points, tmp_path)
    assert snapshot(tmp_path) == before
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("case", CASES)
def test_read_only_folder_is_refused_in_words(case, run_alg, small_scene, points, golden, read_only):
    with read_only(lambda folder: copy_output(golden[case], folder)) as folder:
        before = snapshot(folder)
        with pytest.raises(QgsProcessingException, match=r"(read-only|permission denied)"):
            run_into(run_alg, case, small_scene, points, folder)
        assert snapshot(folder) == before


@pytest.mark.parametrize("case", CASES)
def test_missing_folder_is_refused_in_words(case, run_alg, small_scene, points, tmp_path):
    folder = tmp_path / "no" / "such" / "folder"
    try:
        run_into(run_alg, case, small_scene, points, folder)
    except QgsProcessingException as exc:
        assert "does not exist" in str(exc) or "folder" in str(exc), str(exc)
        assert not (folder / OUTPUTS[case][1]).exists()
    else:  # QGIS creates the folders of file destinations itself: then the output must be complete
        assert members(folder / OUTPUTS[case][1])
        assert leftovers(folder) == []


class CancelBeforeRename(QgsProcessingFeedback):
    """Says 'canceled' once the new output exists as a temporary file (the user pressed Cancel as it was written)."""

    def __init__(self, folder: Path):
        super().__init__()
        self.folder = folder

    def isCanceled(self):
        return bool(leftovers(self.folder)) or super().isCanceled()


@pytest.mark.parametrize("case", CASES)
def test_cancel_before_the_rename_keeps_the_earlier_output(case, run_alg, small_scene, points, golden, tmp_path):
    copy_output(golden[case], tmp_path)
    before = snapshot(tmp_path)
    with pytest.raises(QgsProcessingException, match="Canceled; earlier outputs were left as they were"):
        run_into(run_alg, case, small_scene, points, tmp_path, CancelBeforeRename(tmp_path))
    assert snapshot(tmp_path) == before
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("case", CASES)
def test_existing_output_is_replaced_completely(case, run_alg, small_scene, points, golden, tmp_path):
    """Processing's overwrite: the earlier file is replaced by a complete, readable one (same layer name)."""
    copy_output(golden[case], tmp_path)
    for member in members(tmp_path / OUTPUTS[case][1]):
        member.write_bytes(b"stale")
    result = run_into(run_alg, case, small_scene, points, tmp_path)
    out = tmp_path / OUTPUTS[case][1]
    assert all(m.read_bytes() != b"stale" for m in members(out))
    assert leftovers(tmp_path) == []
    if out.suffix in (".gpkg", ".shp"):
        from osgeo import ogr

        ds = ogr.Open(str(out))
        assert ds.GetLayer(0).GetName() == out.stem and ds.GetLayer(0).GetFeatureCount() > 0
    assert Path(str(result["OUTPUT"]).split("|")[0]) == out
