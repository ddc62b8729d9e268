#!/usr/bin/python3
"""Renders a Runout run's hazard map headless with PyQGIS, the layers styled as QGIS loads them from runout's
outputs: the DEM in grey (or hillshaded), max_depth.tif with its .qml, hazard.gpkg's inundated outline (its layer_styles
style, fill dropped so the depth shows), the structures as built, and the protected zones.

    /usr/bin/python3 qgis/render_result.py RUN_DIR --dem DEM [--zones ZONES] --out PNG [--width 1600]

Prints a JSON summary (each layer's renderer type and where its style came from, the image size) for the
test (tests/qgis/provider_test.py). Run with Debian's python3 (python3-qgis), QT_QPA_PLATFORM=offscreen.
docs/qgis.md has the picture of the flume it made.
"""
import argparse
import json
import os
import sys

# QGIS's grey stretch computes the DEM's statistics; without this GDAL saves them in an .aux.xml beside the DEM
os.environ.setdefault("GDAL_PAM_ENABLED", "NO")

from qgis.core import (QgsApplication, QgsHillshadeRenderer, QgsMapRendererCustomPainterJob, QgsMapSettings,
                       QgsRasterLayer, QgsRectangle, QgsVectorLayer)
from qgis.PyQt.QtCore import QSize, Qt
from qgis.PyQt.QtGui import QColor, QFont, QImage, QPainter


def raster(path, name):
    layer = QgsRasterLayer(path, name)
    if not layer.isValid():
        raise SystemExit(f"{path}: QGIS cannot open it")
    return layer


def vector(uri, name):
    layer = QgsVectorLayer(uri, name, "ogr")
    if not layer.isValid():
        raise SystemExit(f"{uri}: QGIS cannot open it")
    return layer


def styled_layers(run_dir, dem_path, zones_path, hillshade):
    """(layers top first, summary). Styles: runout's own (the .qml beside the raster, the GeoPackage's
    layer_styles, both loaded by QGIS as the layer's default style); the hillshade, outlines and zones are this
    picture's choices."""
    rasters = os.path.join(run_dir, "rasters")
    dem = raster(dem_path, "DEM")
    if hillshade:  # QGIS's default (grey, stretched) suits the flume, whose 0.1 mm steps stripe a hillshade
        dem.setRenderer(QgsHillshadeRenderer(dem.dataProvider(), 1, 315, 45))
    else:
        dem.renderer().setOpacity(0.5)  # over white: the low plain mid-grey, not black
    depth = raster(os.path.join(rasters, "max_depth.tif"), "max_depth")
    msg, ok = depth.loadNamedStyle(os.path.join(rasters, "max_depth.qml"))
    if not ok:
        raise SystemExit(f"max_depth.qml: {msg}")
    gpkg = os.path.join(rasters, "hazard.gpkg")
    inundated = vector(f"{gpkg}|layername=inundated", "inundated")
    inundated_style = inundated.renderer().type()  # from layer_styles, before the fill is dropped
    renderer = inundated.renderer()
    for k, cat in enumerate(renderer.categories()):
        sym = cat.symbol().clone()
        sym.symbolLayer(0).setBrushStyle(Qt.NoBrush)
        sym.symbolLayer(0).setStrokeColor(QColor("#08519c"))
        sym.symbolLayer(0).setStrokeWidth(0.5)
        renderer.updateCategorySymbol(k, sym)
    layers, summary = [], {}
    for uri, name, colour in ((f"{gpkg}|layername=check_dams", "check_dams", "#000000"),
                              (f"{gpkg}|layername=structure_areas", "structure_areas", "#000000"),
                              (zones_path, "zones", "#d7301f")):
        if uri and (not uri.startswith(gpkg) or name in _gpkg_layers(gpkg)):
            layer = vector(uri, name)
            layers.append(layer)
            if uri.startswith(gpkg) and name in _gpkg_styled(gpkg):  # runout's own style, as QGIS loads it
                continue
            sym = layer.renderer().symbol()
            sym.setColor(QColor(colour))
            if layer.geometryType() == 2:  # polygons: outline only
                sym.symbolLayer(0).setBrushStyle(Qt.NoBrush)
                sym.symbolLayer(0).setStrokeColor(QColor(colour))
                sym.symbolLayer(0).setStrokeWidth(0.6)
            else:
                sym.setWidth(1.0)
    layers += [inundated, depth, dem]
    summary = {"max_depth": {"renderer": depth.renderer().type(), "style": "max_depth.qml"},
               "inundated": {"renderer": inundated_style, "style": "layer_styles"},
               "dem": {"renderer": dem.renderer().type()},
               "layers": [layer.name() for layer in layers]}
    return layers, summary


def _gpkg_layers(gpkg):
    import sqlite3
    with sqlite3.connect(f"file:{gpkg}?mode=ro", uri=True) as db:
        return {r[0] for r in db.execute("SELECT table_name FROM gpkg_contents")}


def _gpkg_styled(gpkg):
    """The layers with a default style in the GeoPackage's layer_styles (runouts before the structures' styles
    wrote none for check_dams and structure_areas: this picture then styles them itself)."""
    import sqlite3
    with sqlite3.connect(f"file:{gpkg}?mode=ro", uri=True) as db:
        if not db.execute("SELECT 1 FROM sqlite_master WHERE name = 'layer_styles'").fetchone():
            return set()
        return {r[0] for r in db.execute("SELECT f_table_name FROM layer_styles WHERE useAsDefault = 1")}


def render(layers, extent, crs, width, title):
    """The map below a white strip with the title."""
    settings = QgsMapSettings()
    settings.setLayers(layers)
    settings.setDestinationCrs(crs)
    height = max(200, round(width * extent.height() / extent.width()))
    settings.setOutputSize(QSize(width, height))
    settings.setExtent(extent)
    settings.setBackgroundColor(QColor("white"))
    header = 30 if title else 0
    image = QImage(QSize(width, height + header), QImage.Format_RGB32)
    image.fill(QColor("white"))
    painter = QPainter(image)
    painter.translate(0, header)
    QgsMapRendererCustomPainterJob(settings, painter).renderSynchronously()
    painter.resetTransform()
    painter.setPen(QColor("black"))
    painter.setFont(QFont("DejaVu Sans", 11))
    painter.drawText(10, 20, title)
    painter.end()
    return image


def draw(args):
    layers, summary = styled_layers(args.run_dir, args.dem, args.zones, args.hillshade)
    dem = layers[-1]
    image = render(layers, QgsRectangle(dem.extent()), dem.crs(), args.width, args.title)
    if not image.save(args.out):
        raise SystemExit(f"--out: cannot write {args.out}")
    summary["image"] = {"path": args.out, "width": image.width(), "height": image.height()}
    return summary


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run_dir")
    ap.add_argument("--dem", required=True)
    ap.add_argument("--zones")
    ap.add_argument("--out", required=True)
    ap.add_argument("--width", type=int, default=1600)
    ap.add_argument("--title", default="")
    ap.add_argument("--hillshade", action="store_true", help="hillshade the DEM instead of QGIS's grey stretch")
    args = ap.parse_args()
    app = QgsApplication([], False)
    app.initQgis()
    summary = draw(args)
    json.dump(summary, sys.stdout)
    print()
    app.exitQgis()  # after the layers are gone: PyQGIS crashes at exit when layers outlive the registry


if __name__ == "__main__":
    main()
