"""The temp-file-and-rename protocol shared by every writer."""

import errno
import os

import pytest

from monoplot_plugin.outputs.safe_write import OutputError, OutputExistsError, atomic_output, describe_os_error


def test_exception_in_writer_removes_temporary_files_and_keeps_old(tmp_path):
    target = tmp_path / "glacier.shp"
    for suffix in (".shp", ".shx", ".dbf", ".prj"):
        (tmp_path / f"glacier{suffix}").write_text("old" + suffix)
    with pytest.raises(ZeroDivisionError):
        with atomic_output(target, overwrite=True) as tmp:
            base = tmp[:-4]
            for suffix in (".shp", ".shx", ".dbf"):
                with open(base + suffix, "w") as fh:
                    fh.write("new")
            raise ZeroDivisionError
    assert sorted(os.listdir(tmp_path)) == ["glacier.dbf", "glacier.prj", "glacier.shp", "glacier.shx"]
    assert (tmp_path / "glacier.dbf").read_text() == "old.dbf"


def test_shapefile_members_replaced_together_and_stale_ones_removed(tmp_path):
    for suffix in (".shp", ".shx", ".dbf", ".cpg"):
        (tmp_path / f"g{suffix}").write_text("old")
    with pytest.raises(OutputExistsError):
        with atomic_output(tmp_path / "g.shp"):
            pass
    with atomic_output(tmp_path / "g.shp", overwrite=True) as tmp:
        for suffix in (".shp", ".shx", ".dbf"):
            with open(tmp[:-4] + suffix, "w") as fh:
                fh.write("new")
    assert sorted(os.listdir(tmp_path)) == ["g.dbf", "g.shp", "g.shx"]  # the old .cpg does not describe the new
    assert all((tmp_path / f"g{s}").read_text() == "new" for s in (".shp", ".shx", ".dbf"))


def test_writer_that_writes_nothing_is_an_error(tmp_path):
    with pytest.raises(OutputError, match="was not written"):
        with atomic_output(tmp_path / "x.tif"):
            pass
    assert os.listdir(tmp_path) == []


def test_reasons_are_plain_words():
    assert "disk is full" in describe_os_error(OSError(errno.ENOSPC, "No space left on device"), "/d/x.tif")
    assert "read-only" in describe_os_error(OSError(errno.EROFS, "Read-only file system"), "/d/x.tif")
    assert "permission denied" in describe_os_error(OSError(errno.EACCES, "Permission denied"), "/d/x.tif")
