"""Every Monoplot Processing algorithm, one instance each (the provider registers them)."""


def all_algorithms():
    from .autoregister import AutoRegister
    from .batch import BatchPhotos
    from .fit import FitCamera
    from .products import ComputeXyz, MapToPhoto, Orthophoto, PhotoToMap, Report
    from .suggest import SuggestDemPoints, SuggestPhotoPoints

    return [SuggestPhotoPoints(), SuggestDemPoints(), FitCamera(), ComputeXyz(), PhotoToMap(), MapToPhoto(),
            Orthophoto(), Report(), BatchPhotos(), AutoRegister()]
