"""The batch of the Processing algorithm: :mod:`..workflow.batch` (threads on this machine) and
:mod:`..workflow.cluster` (a Dask scheduler's workers), under Processing's names."""

from ..workflow.batch import (  # noqa: F401 (the algorithm's names for them)
    LOG_NAME,
    WARNING,
    PhotoJob,
    PhotoResult,
    fit_shared_camera,
    folder_jobs,
    other_viewpoints_hint,
    output_stems,
    run_batch,
    shared_camera_verdict,
    table_jobs,
    write_log,
)


def run_batch_dask(*args, **kwargs):
    """:func:`..workflow.cluster.run_batch_dask` (Dask imported only when a scheduler is given)."""
    from ..workflow.cluster import run_batch_dask as run

    return run(*args, **kwargs)
