"""Writes a Runout scene (docs/scene-format.md) from QGIS layers.

Geometry goes into the scene inline, in the DEM's CRS (QGIS reprojects), so the scene is self-contained and
the service can run it; attributes come from the layers' fields, named as the scene's keys (crest_height,
thickness, ...). A value the layer leaves empty is left out of the scene, so runout's own validator refuses
it and names the accepted range; `Provenance` turns the scene path in that message back into the layer and
feature it came from.
"""
import json
import re

from qgis.core import QgsCoordinateTransform, QgsProcessingException, QgsWkbTypes

# Fields read per object, as the scene's keys (docs/scene-format.md, "structures"). A check dam's slit is
# flattened: slit_width, slit_bottom.
CHECK_DAM_FIELDS = ("crest_height", "thickness")
AREA_FIELDS = {
    "deposition_area": ("elevation", "gradient"),
    "retention_basin": ("depth", "wall_height", "wall_thickness", "open_edges"),
}
RELEASE_FIELDS = ("depth", "volume")
HYDROGRAPH_FIELDS = ("depth", "discharge", "volume", "duration")


class Provenance:
    """Which layer and feature each part of the scene came from, to name them in runout's refusals."""

    def __init__(self):
        self.origin = {}

    def add(self, path, text):
        self.origin[path] = text

    def explain(self, message):
        """runout's `FIELD: what is wrong (accepted range)` with the layer, feature and field named."""
        m = re.search(r"\b((structures|protected_zones|monitors)\[\d+\]|release\.hydrograph|release|terrain\.corridor)"
                      r"(\.([A-Za-z_]+))?", message)
        if not m or m.group(1) not in self.origin:
            return message
        where = self.origin[m.group(1)]
        field = f", field {m.group(4)}" if m.group(4) else ""
        return f"{message.strip()} -- in {where}{field}"


def _value(feature, field):
    """The field's value, None when the layer has no such field or it is NULL; numbers as float."""
    if feature.fields().indexOf(field) < 0:
        return None
    v = feature[field]
    if v is None or (hasattr(v, "isNull") and v.isNull()) or str(v) == "NULL":
        return None
    if isinstance(v, (int, float)) and not isinstance(v, bool):
        return float(v)
    s = str(v).strip()
    if s == "":
        return None
    try:
        return float(s)
    except ValueError:
        pass
    try:
        return json.loads(s)  # a discharge series [[t, Q], ...] or open_edges [0, 2]
    except ValueError:
        return s  # runout refuses it, naming the field and what it accepts


def _name(feature, fallback):
    v = _value(feature, "name")
    return str(v if not isinstance(v, float) else int(v)) if v is not None else fallback


def _where(source, feature):
    return f"layer '{source.sourceName()}' feature {feature.id()}"


def _transform(source, crs, context):
    return QgsCoordinateTransform(source.sourceCrs(), crs, context.transformContext())


def _points(geometry, source, feature, what):
    if geometry.isMultipart():
        parts = geometry.asGeometryCollection()
        if len(parts) != 1:
            raise QgsProcessingException(f"{what}: {_where(source, feature)} has {len(parts)} parts (accepted: one)")
        geometry = parts[0]
    if geometry.type() == QgsWkbTypes.PolygonGeometry:
        rings = geometry.asPolygon()
        if len(rings) != 1:
            raise QgsProcessingException(f"{what}: {_where(source, feature)} has {len(rings) - 1} holes "
                                         "(accepted: a polygon without holes)")
        pts = rings[0][:-1]  # the closing vertex, as runout drops it
    elif geometry.type() == QgsWkbTypes.LineGeometry:
        pts = geometry.asPolyline()
    else:
        raise QgsProcessingException(f"{what}: {_where(source, feature)} is not a line or polygon")
    return [[round(p.x(), 6), round(p.y(), 6)] for p in pts]  # to the micrometre: no transform noise in the scene


def _features(source, crs, context, what):
    """(feature, [[x, y], ...] in crs) for every feature of the source."""
    xform = _transform(source, crs, context)
    for f in source.getFeatures():
        g = f.geometry()
        if g is None or g.isEmpty():
            raise QgsProcessingException(f"{what}: {_where(source, f)} has no geometry")
        g.transform(xform)
        yield f, _points(g, source, f, what)


def _copy_fields(target, feature, fields):
    for k in fields:
        v = _value(feature, k)
        if v is not None:
            target[k] = v


def release_of(source, crs, context, prov, material):
    found = list(_features(source, crs, context, "release"))
    if len(found) != 1:
        raise QgsProcessingException(f"release: layer '{source.sourceName()}' has {len(found)} features "
                                     "(accepted: one polygon with a depth or volume field)")
    f, ring = found[0]
    r = {"polygon": ring, "material": material}
    _copy_fields(r, f, RELEASE_FIELDS)
    prov.add("release", f"the release ({_where(source, f)}; fields depth or volume)")
    return r


def hydrograph_of(source, crs, context, prov, material):
    found = list(_features(source, crs, context, "hydrograph"))
    if len(found) != 1:
        raise QgsProcessingException(f"hydrograph: layer '{source.sourceName()}' has {len(found)} features "
                                     "(accepted: one line with fields depth and discharge, or volume and duration)")
    f, line = found[0]
    h = {"line": line}
    _copy_fields(h, f, HYDROGRAPH_FIELDS)
    prov.add("release.hydrograph", f"the hydrograph line ({_where(source, f)})")
    return {"hydrograph": h, "material": material}


def check_dams_of(source, crs, context, prov, first_index):
    out = []
    for f, axis in _features(source, crs, context, "check dams"):
        s = {"type": "check_dam", "name": _name(f, f"CD_{f.id()}"), "axis": axis}
        _copy_fields(s, f, CHECK_DAM_FIELDS)
        slit = {}
        for key in ("width", "bottom"):
            v = _value(f, "slit_" + key)
            if v is not None:
                slit[key] = v
        if slit:
            s["slit"] = slit
        prov.add(f"structures[{first_index + len(out)}]", f"check dam '{s['name']}' ({_where(source, f)})")
        out.append(s)
    return out


def structure_areas_of(source, crs, context, prov, first_index):
    out = []
    for f, ring in _features(source, crs, context, "structure areas"):
        kind = _value(f, "type")
        if kind not in AREA_FIELDS:
            raise QgsProcessingException(f"structure areas: {_where(source, f)} field type is {kind!r} "
                                         f"(accepted: {', '.join(AREA_FIELDS)})")
        s = {"type": kind, "name": _name(f, f"{'FD' if kind == 'deposition_area' else 'RB'}_{f.id()}"),
             "polygon": ring}
        _copy_fields(s, f, AREA_FIELDS[kind])
        prov.add(f"structures[{first_index + len(out)}]", f"{kind} '{s['name']}' ({_where(source, f)})")
        out.append(s)
    return out


def zones_of(source, crs, context, prov):
    out = []
    for f, ring in _features(source, crs, context, "protected zones"):
        z = {"name": _name(f, f"Zone{f.id()}"), "polygon": ring}
        prov.add(f"protected_zones[{len(out)}]", f"protected zone '{z['name']}' ({_where(source, f)})")
        out.append(z)
    return out


def sections_of(source, crs, context, prov):
    out = []
    for f, line in _features(source, crs, context, "sections"):
        m = {"type": "section", "name": _name(f, f"S{f.id()}"), "line": line}
        prov.add(f"monitors[{len(out)}]", f"section '{m['name']}' ({_where(source, f)})")
        out.append(m)
    return out


def corridor_of(source, crs, context, prov):
    found = list(_features(source, crs, context, "corridor"))
    if len(found) != 1:
        raise QgsProcessingException(f"corridor: layer '{source.sourceName()}' has {len(found)} features "
                                     "(accepted: one polygon without holes)")
    prov.add("terrain.corridor", f"the corridor ({_where(source, found[0][0])})")
    return {"polygon": found[0][1]}
