"""The Processing provider `runout`: its algorithms are runout:runscene and runout:comparelayouts."""
from qgis.core import QgsProcessingProvider

from .alg_compare import CompareLayoutsAlgorithm
from .alg_run_scene import RunSceneAlgorithm


class RunoutProvider(QgsProcessingProvider):
    def id(self):
        return "runout"

    def name(self):
        return "Runout"

    def longName(self):  # noqa: N802
        return "Runout debris-flow hazard mitigation"

    def loadAlgorithms(self):  # noqa: N802
        self.addAlgorithm(RunSceneAlgorithm())
        self.addAlgorithm(CompareLayoutsAlgorithm())
