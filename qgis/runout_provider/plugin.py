"""Registers the provider, in the desktop (initGui) and in qgis_process (initProcessing)."""
from qgis.core import QgsApplication

from .provider import RunoutProvider


class RunoutPlugin:
    def __init__(self, iface):
        self.iface = iface
        self.provider = None

    def initProcessing(self):  # noqa: N802 (QGIS's name): qgis_process calls it, without a GUI
        if self.provider is None:
            self.provider = RunoutProvider()
            QgsApplication.processingRegistry().addProvider(self.provider)

    def initGui(self):  # noqa: N802
        self.initProcessing()

    def unload(self):
        if self.provider is not None:
            QgsApplication.processingRegistry().removeProvider(self.provider)
            self.provider = None
