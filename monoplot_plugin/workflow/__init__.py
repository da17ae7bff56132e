"""Monoplot's steps, each written once, under the dock (gui/) and the Processing algorithms (processing/).

No Qt and no qgis here: the steps run in worker threads and in plain scripts. Every step takes the same two
callbacks, ``progress(fraction in [0, 1], message)`` and ``is_canceled()``, and stops with
:class:`~.progress.Canceled` (see :mod:`.progress`).
"""
