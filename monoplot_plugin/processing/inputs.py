"""The input readers of the algorithms: they live in :mod:`..workflow.files` (the batch needs them without qgis)."""

from ..workflow.files import (  # noqa: F401 (the algorithms' names for them)
    MAP_COLUMNS,
    PHOTO_COLUMNS,
    InputError,
    load_camera,
    photo_size,
    read_photo,
    read_points_csv,
    write_points_csv,
)
