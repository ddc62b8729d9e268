// QGIS layer styles (.qml) for the hazard rasters: a colour ramp or a palette, so a raster dropped into QGIS
// shows with its legend rather than in grey.
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include "runout/terrain/raster.hpp"
#include "runout/terrain/terrain.hpp"

namespace runout::terrain {
namespace {

std::string xml_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

// "#rrggbb" as QGIS writes a colour ("r,g,b,a"), darkened by `shade`, with opacity `alpha` (0-255).
std::string qgis_colour(const std::string& hex, double shade = 1.0, int alpha = 255) {
  if (hex.size() != 7 || hex[0] != '#') throw std::invalid_argument("colour '" + hex + "' is not #rrggbb");
  std::string out;
  for (int k = 0; k < 3; ++k)
    out += std::to_string(static_cast<int>(std::stoi(hex.substr(1 + 2 * k, 2), nullptr, 16) * shade)) + ",";
  return out + std::to_string(alpha);
}

}  // namespace

std::string vector_class_qml(const std::string& field, const std::vector<StyleStop>& categories) {
  if (categories.empty()) throw std::invalid_argument("vector_class_qml: no categories for field '" + field + "'");
  std::ostringstream q;
  q << "<!DOCTYPE qgis PUBLIC 'http://mrcc.com/qgis.dtd' 'SYSTEM'>\n"
    << "<qgis version=\"3.28.0\" styleCategories=\"Symbology\">\n"
    << "  <renderer-v2 type=\"categorizedSymbol\" attr=\"" << xml_escape(field)
    << "\" symbollevels=\"0\" enableorderby=\"0\" forceraster=\"0\">\n    <categories>\n";
  for (size_t k = 0; k < categories.size(); ++k)
    q << "      <category value=\"" << number(categories[k].value) << "\" symbol=\"" << k << "\" label=\""
      << xml_escape(categories[k].label) << "\" render=\"true\"/>\n";
  q << "    </categories>\n    <symbols>\n";
  for (size_t k = 0; k < categories.size(); ++k)
    q << "      <symbol type=\"fill\" name=\"" << k << "\" alpha=\"0.8\" clip_to_extent=\"1\" force_rhr=\"0\">\n"
      << "        <layer class=\"SimpleFill\" enabled=\"1\" pass=\"0\" locked=\"0\">\n          <Option type=\"Map\">\n"
      << "            <Option type=\"QString\" name=\"color\" value=\"" << qgis_colour(categories[k].colour) << "\"/>\n"
      << "            <Option type=\"QString\" name=\"outline_color\" value=\"" << qgis_colour(categories[k].colour, 0.6)
      << "\"/>\n            <Option type=\"QString\" name=\"outline_style\" value=\"solid\"/>\n"
      << "            <Option type=\"QString\" name=\"outline_width\" value=\"0.26\"/>\n"
      << "            <Option type=\"QString\" name=\"outline_width_unit\" value=\"MM\"/>\n"
      << "            <Option type=\"QString\" name=\"style\" value=\"solid\"/>\n          </Option>\n"
      << "        </layer>\n      </symbol>\n";
  q << "    </symbols>\n  </renderer-v2>\n  <blendMode>0</blendMode>\n  <featureBlendMode>0</featureBlendMode>\n"
    << "  <layerOpacity>1</layerOpacity>\n</qgis>\n";
  return q.str();
}

namespace {

// Each feature's `name` written beside it (QGIS simple labelling), for the built structures.
std::string name_labels(bool on_line) {
  std::ostringstream q;
  q << "  <labeling type=\"simple\">\n    <settings calloutType=\"simple\">\n"
    << "      <text-style fieldName=\"name\" isExpression=\"0\" fontSize=\"9\" fontSizeUnit=\"Point\" "
    << "textColor=\"20,20,20,255\" fontWeight=\"75\">\n"
    << "        <text-buffer bufferDraw=\"1\" bufferSize=\"1\" bufferSizeUnits=\"MM\" bufferColor=\"255,255,255,255\"/>\n"
    << "      </text-style>\n      <placement placement=\"" << (on_line ? 2 : 1) << "\" dist=\"1\" distUnits=\"MM\"/>\n"
    << "    </settings>\n  </labeling>\n";
  return q.str();
}

}  // namespace

std::string structure_layer_qml(bool areas) {
  std::ostringstream q;
  q << "<!DOCTYPE qgis PUBLIC 'http://mrcc.com/qgis.dtd' 'SYSTEM'>\n"
    << "<qgis version=\"3.28.0\" styleCategories=\"Symbology|Labeling\" labelsEnabled=\"1\">\n";
  if (!areas) {  // a wall's axis (a check dam's crest line): thick, dark, above every fill
    std::string colour = "#3b3b3b";
    for (const auto* t : structure_types())
      if (!t->area) colour = t->colour;
    q << "  <renderer-v2 type=\"singleSymbol\" symbollevels=\"0\" enableorderby=\"0\" forceraster=\"0\">\n"
      << "    <symbols>\n      <symbol type=\"line\" name=\"0\" alpha=\"1\" clip_to_extent=\"1\" force_rhr=\"0\">\n"
      << "        <layer class=\"SimpleLine\" enabled=\"1\" pass=\"0\" locked=\"0\">\n          <Option type=\"Map\">\n"
      << "            <Option type=\"QString\" name=\"line_color\" value=\"" << qgis_colour(colour) << "\"/>\n"
      << "            <Option type=\"QString\" name=\"line_width\" value=\"1.2\"/>\n"
      << "            <Option type=\"QString\" name=\"line_width_unit\" value=\"MM\"/>\n"
      << "            <Option type=\"QString\" name=\"capstyle\" value=\"flat\"/>\n          </Option>\n"
      << "        </layer>\n      </symbol>\n    </symbols>\n  </renderer-v2>\n";
  } else {  // deposition areas and retention basins: outlined, lightly filled so the hazard under them shows
    std::vector<const StructureType*> kinds;  // the area types, each in its own colour
    for (const auto* t : structure_types())
      if (t->area) kinds.push_back(t);
    q << "  <renderer-v2 type=\"categorizedSymbol\" attr=\"type\" symbollevels=\"0\" enableorderby=\"0\" "
      << "forceraster=\"0\">\n    <categories>\n";
    for (size_t k = 0; k < kinds.size(); ++k)
      q << "      <category value=\"" << kinds[k]->name << "\" symbol=\"" << k << "\" label=\"" << kinds[k]->label
        << "\" render=\"true\"/>\n";
    q << "    </categories>\n    <symbols>\n";
    for (size_t k = 0; k < kinds.size(); ++k)
      q << "      <symbol type=\"fill\" name=\"" << k << "\" alpha=\"1\" clip_to_extent=\"1\" force_rhr=\"0\">\n"
        << "        <layer class=\"SimpleFill\" enabled=\"1\" pass=\"0\" locked=\"0\">\n          <Option type=\"Map\">\n"
        << "            <Option type=\"QString\" name=\"color\" value=\"" << qgis_colour(kinds[k]->colour, 1.0, 64) << "\"/>\n"
        << "            <Option type=\"QString\" name=\"outline_color\" value=\"" << qgis_colour(kinds[k]->colour) << "\"/>\n"
        << "            <Option type=\"QString\" name=\"outline_style\" value=\"solid\"/>\n"
        << "            <Option type=\"QString\" name=\"outline_width\" value=\"0.6\"/>\n"
        << "            <Option type=\"QString\" name=\"outline_width_unit\" value=\"MM\"/>\n"
        << "            <Option type=\"QString\" name=\"style\" value=\"solid\"/>\n          </Option>\n"
        << "        </layer>\n      </symbol>\n";
    q << "    </symbols>\n  </renderer-v2>\n";
  }
  q << name_labels(!areas) << "  <blendMode>0</blendMode>\n  <featureBlendMode>0</featureBlendMode>\n"
    << "  <layerOpacity>1</layerOpacity>\n</qgis>\n";
  return q.str();
}

void write_qml(const std::string& path, const std::vector<StyleStop>& stops, bool classes) {
  if (stops.empty()) throw std::invalid_argument("write_qml: no colour stops for '" + path + "'");
  std::ostringstream q;
  q << "<!DOCTYPE qgis PUBLIC 'http://mrcc.com/qgis.dtd' 'SYSTEM'>\n"
    << "<qgis version=\"3.28.0\" styleCategories=\"Symbology\">\n  <pipe>\n";
  if (classes) {
    q << "    <rasterrenderer type=\"paletted\" band=\"1\" opacity=\"0.8\" alphaBand=\"-1\" nodataColor=\"\">\n"
      << "      <colorPalette>\n";
    for (const auto& s : stops)
      q << "        <paletteEntry value=\"" << number(s.value) << "\" color=\"" << s.colour << "\" alpha=\"255\" label=\""
        << xml_escape(s.label) << "\"/>\n";
    q << "      </colorPalette>\n";
  } else {
    q << "    <rasterrenderer type=\"singlebandpseudocolor\" band=\"1\" opacity=\"0.8\" alphaBand=\"-1\" "
      << "classificationMin=\"" << number(stops.front().value) << "\" classificationMax=\"" << number(stops.back().value)
      << "\" nodataColor=\"\">\n      <rastershader>\n"
      // clip="1": values outside the ramp (a depth under the inundation threshold) are not painted, as on the
      // web map, rather than in the end colours over the whole window.
      << "        <colorrampshader colorRampType=\"INTERPOLATED\" classificationMode=\"1\" clip=\"1\" minimumValue=\""
      << number(stops.front().value) << "\" maximumValue=\"" << number(stops.back().value) << "\">\n";
    for (const auto& s : stops)
      q << "          <item value=\"" << number(s.value) << "\" color=\"" << s.colour << "\" alpha=\"255\" label=\""
        << xml_escape(s.label) << "\"/>\n";
    q << "        </colorrampshader>\n      </rastershader>\n";
  }
  q << "    </rasterrenderer>\n  </pipe>\n  <blendMode>0</blendMode>\n</qgis>\n";
  const std::string tmp = path + ".tmp";
  {
    std::ofstream out(tmp);
    out << q.str();
    if (!out) throw std::runtime_error("write_qml: cannot write '" + tmp + "'");
  }
  std::filesystem::rename(tmp, path);
}

}  // namespace runout::terrain
