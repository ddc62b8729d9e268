// The study report: one self-contained HTML file of a sweep's layouts (report.hpp, docs/report.md).
#include "runout/scenarios/report.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <map>
#include <optional>
#include <set>
#include <sstream>
#include <stdexcept>

#include <nlohmann/json.hpp>

#include "runout/common/base64.hpp"
#include "runout/scenarios/decision_metrics.hpp"
#include "runout/scenarios/raster_map.hpp"
#include "runout/scenarios/scene_map.hpp"
#include "runout/scenarios/tradeoff.hpp"
#include "runout/terrain/raster.hpp"

namespace runout {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string html_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (const char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

namespace {

std::string fmt(double v, const char* f = "%.4g") {
  char b[64];
  std::snprintf(b, sizeof b, f, v);
  return b;
}

// A value as JSON writes it: the shortest text that reads back as the same double (data-value attributes).
std::string exact(double v) { return json(v).dump(); }

std::string read_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Categorical colours (Tableau 10), one per layout in the order of the sweep; the baseline is drawn in black.
const char* layout_colour(size_t k) {
  static const char* c[] = {"#4e79a7", "#f28e2b", "#e15759", "#76b7b2", "#59a14f",
                            "#edc948", "#b07aa1", "#ff9da7", "#9c755f", "#bab0ac"};
  return c[k % 10];
}

// One layout of the report, with what the store holds of it.
struct Layout {
  ReportRun run;
  RunStore::RunRow row;
  std::map<std::string, double> metrics;
  json manifest;
  bool baseline = false;
  std::string colour;
};

std::optional<double> metric(const Layout& l, const std::string& name) {
  const auto it = l.metrics.find(name);
  return it == l.metrics.end() ? std::nullopt : std::optional<double>(it->second);
}

// The column heading of a decision metric: what it is, of which subject, in which unit.
std::string metric_heading(const DecisionMetrics& d, const std::string& name) { return d.label(name); }

const char* group_name(int group) {
  static const char* names[] = {"", "outlet", "outlet", "peak loads", "retained volumes", "inundation",
                                "protected zones", "runout"};
  return group >= 1 && group <= 7 ? names[group] : "";
}

// ---- charts ----------------------------------------------------------------------------------------------

struct Line {
  std::string label, colour;
  bool dashed = false;
  std::vector<std::array<double, 2>> points;
};

// Tick values over [lo, hi]: about five, on 1, 2, 5 x 10^k.
std::vector<double> ticks(double lo, double hi) {
  const double span = hi - lo;
  const double raw = span / 5, mag = std::pow(10.0, std::floor(std::log10(raw)));
  const double step = raw / mag < 1.5 ? mag : raw / mag < 3.5 ? 2 * mag : raw / mag < 7.5 ? 5 * mag : 10 * mag;
  std::vector<double> out;
  for (double v = std::ceil(lo / step) * step; v <= hi + 1e-9 * span; v += step) out.push_back(std::abs(v) < 1e-12 * span ? 0 : v);
  return out;
}

// A series thinned to at most ~2 points per pixel column, keeping each bucket's extremes (peaks survive).
std::vector<std::array<double, 2>> thin(const std::vector<std::array<double, 2>>& p, size_t buckets) {
  if (p.size() <= 2 * buckets) return p;
  std::vector<std::array<double, 2>> out;
  const size_t per = (p.size() + buckets - 1) / buckets;
  for (size_t b = 0; b < p.size(); b += per) {
    const size_t e = std::min(p.size(), b + per);
    auto [lo, hi] = std::minmax_element(p.begin() + b, p.begin() + e,
                                        [](const auto& a, const auto& c) { return a[1] < c[1]; });
    if (lo < hi) out.push_back(*lo), out.push_back(*hi);
    else out.push_back(*hi), out.push_back(*lo);
  }
  return out;
}

// An SVG line chart with axes, ticks, units and a legend of the lines beside the plot.
std::string line_chart(const std::string& title, const std::string& x_label, const std::string& y_label,
                       const std::vector<Line>& lines) {
  const double W = 720, H = 300, L = 72, R = 130, T = 30, B = 46, pw = W - L - R, ph = H - T - B;
  double x0 = 1e300, x1 = -1e300, y0 = 0, y1 = -1e300;
  for (const auto& l : lines)
    for (const auto& p : l.points) x0 = std::min(x0, p[0]), x1 = std::max(x1, p[0]), y0 = std::min(y0, p[1]), y1 = std::max(y1, p[1]);
  if (!(x1 > x0)) x0 = 0, x1 = 1;
  if (!(y1 > y0)) y1 = y0 + 1;
  y1 += 0.05 * (y1 - y0);
  auto X = [&](double x) { return L + (x - x0) / (x1 - x0) * pw; };
  auto Y = [&](double y) { return T + ph - (y - y0) / (y1 - y0) * ph; };
  std::ostringstream s;
  s << "<svg class=\"chart\" viewBox=\"0 0 " << W << ' ' << H << "\" role=\"img\" aria-label=\"" << html_escape(title)
    << "\"><text x=\"" << L << "\" y=\"18\" class=\"ct\">" << html_escape(title) << "</text>";
  s << "<rect x=\"" << L << "\" y=\"" << T << "\" width=\"" << pw << "\" height=\"" << ph << "\" class=\"plot\"/>";
  for (double v : ticks(x0, x1))
    s << "<line x1=\"" << X(v) << "\" x2=\"" << X(v) << "\" y1=\"" << T << "\" y2=\"" << T + ph << "\" class=\"grid\"/>"
      << "<text x=\"" << X(v) << "\" y=\"" << T + ph + 15 << "\" text-anchor=\"middle\">" << fmt(v, "%g") << "</text>";
  for (double v : ticks(y0, y1))
    s << "<line x1=\"" << L << "\" x2=\"" << L + pw << "\" y1=\"" << Y(v) << "\" y2=\"" << Y(v) << "\" class=\"grid\"/>"
      << "<text x=\"" << L - 6 << "\" y=\"" << Y(v) + 4 << "\" text-anchor=\"end\">" << fmt(v, "%g") << "</text>";
  if (y0 < 0)  // a sign to read (a load that turns negative): the zero line drawn, not only a grid line
    s << "<line x1=\"" << L << "\" x2=\"" << L + pw << "\" y1=\"" << Y(0) << "\" y2=\"" << Y(0) << "\" class=\"zero\"/>";
  s << "<text x=\"" << L + pw / 2 << "\" y=\"" << H - 8 << "\" text-anchor=\"middle\">" << html_escape(x_label) << "</text>"
    << "<text transform=\"translate(16 " << T + ph / 2 << ") rotate(-90)\" text-anchor=\"middle\">"
    << html_escape(y_label) << "</text>";
  for (size_t k = 0; k < lines.size(); ++k) {
    const Line& l = lines[k];
    s << "<polyline class=\"series\" data-label=\"" << html_escape(l.label) << "\" stroke=\"" << l.colour << '"'
      << (l.dashed ? " stroke-dasharray=\"6 3\"" : "") << " points=\"";
    for (const auto& p : thin(l.points, static_cast<size_t>(pw))) s << fmt(X(p[0]), "%.1f") << ',' << fmt(Y(p[1]), "%.1f") << ' ';
    s << "\"/>";
    const double ly = T + 8 + 16 * static_cast<double>(k);
    s << "<line x1=\"" << W - R + 12 << "\" x2=\"" << W - R + 36 << "\" y1=\"" << ly << "\" y2=\"" << ly << "\" stroke=\""
      << l.colour << "\" stroke-width=\"2\"" << (l.dashed ? " stroke-dasharray=\"6 3\"" : "") << "/><text x=\""
      << W - R + 42 << "\" y=\"" << ly + 4 << "\">" << html_escape(l.label) << "</text>";
  }
  s << "</svg>";
  return s.str();
}

// Two columns (t and `column`) of a stored series CSV; empty when the series or the column is missing.
std::vector<std::array<double, 2>> series_column(const std::string& csv, const std::string& column) {
  std::istringstream in(csv);
  std::string line, cell;
  if (!std::getline(in, line)) return {};
  std::vector<std::string> head;
  for (std::istringstream h(line); std::getline(h, cell, ',');) head.push_back(cell);
  const auto at = std::find(head.begin(), head.end(), column);
  if (head.empty() || head[0] != "t" || at == head.end()) return {};
  const size_t col = static_cast<size_t>(at - head.begin());
  std::vector<std::array<double, 2>> out;
  while (std::getline(in, line)) {
    std::istringstream r(line);
    std::vector<double> v;
    for (; std::getline(r, cell, ',');) v.push_back(std::strtod(cell.c_str(), nullptr));
    if (v.size() > col && std::isfinite(v[0]) && std::isfinite(v[col])) out.push_back({v[0], v[col]});
  }
  return out;
}

// One chart per monitor of a type (section_*, structure_load_*): each layout that has it is a line.
std::string monitor_charts(const RunStore& store, const std::vector<Layout>& layouts, const std::string& prefix,
                           const std::string& column, const std::string& what, const std::string& unit) {
  std::set<std::string, decltype(&natural_less)> names(&natural_less);
  for (const auto& l : layouts)
    for (const auto& n : store.series_names(l.run.run_id))
      if (n.rfind(prefix, 0) == 0) names.insert(n.substr(prefix.size()));
  std::ostringstream s;
  for (const auto& name : names) {
    std::vector<Line> lines;
    for (const auto& l : layouts) {
      const auto csv = store.series_csv(l.run.run_id, prefix + name);
      if (!csv) continue;
      Line line{l.run.label, l.colour, l.baseline, series_column(*csv, column)};
      if (!line.points.empty()) lines.push_back(std::move(line));
    }
    if (lines.empty()) continue;
    // Loads of a catchment's dams run to MN: the axis in kN or MN rather than 1e+06.
    double top = 0;
    for (const auto& l : lines)
      for (const auto& p : l.points) top = std::max(top, std::abs(p[1]));
    std::string shown_unit = unit;
    if (unit == "N" && top >= 1e4) {
      const double f = top >= 1e7 ? 1e-6 : 1e-3;
      shown_unit = top >= 1e7 ? "MN" : "kN";
      for (auto& l : lines)
        for (auto& p : l.points) p[1] *= f;
    }
    s << "<figure class=\"chart\" data-monitor=\"" << html_escape(name) << "\">"
      << line_chart(what + " at " + name, "time [s]", what + " [" + shown_unit + "]", lines) << "</figure>";
  }
  return s.str();
}

// ---- the ranking table -------------------------------------------------------------------------------------

// The decision metrics of any layout, in rank order.
std::vector<std::string> decision_columns(const std::vector<Layout>& layouts, const DecisionMetrics& d) {
  std::set<std::string> all;
  for (const auto& l : layouts)
    for (const auto& [name, v] : l.metrics) all.insert(name);
  return d.order(std::vector<std::string>(all.begin(), all.end()), false);
}

// Whether two values of the ranking key tie: they print the same in the table (fmt's 4 significant digits).
// The table is what the reader ranks by; an order decided by digits it does not show (C2 and C3 both 0.02215,
// apart in the last bits of their sums) would look arbitrary, and the outlet's Q_m is not resolved that finely
// anyway (a particle crossing the section is a step of dp^3 / window: 0.0125 m³/s on the flume at draft).
bool ties(double a, double b) { return fmt(a) == fmt(b); }

// Layouts ranked by the outlet's Q_m, lowest (the most protective) first, ties (above) by name; layouts
// without it last, by name.
std::vector<const Layout*> ranked(const std::vector<Layout>& layouts, const std::string& key) {
  std::vector<const Layout*> out;
  for (const auto& l : layouts) out.push_back(&l);
  std::stable_sort(out.begin(), out.end(), [&](const Layout* a, const Layout* b) {
    const auto qa = metric(*a, key), qb = metric(*b, key);
    if (qa && qb && !ties(*qa, *qb)) return *qa < *qb;
    if (qa.has_value() != qb.has_value()) return qa.has_value();
    return natural_less(a->run.label, b->run.label);
  });
  return out;
}

// A column of the ranking table: one decision metric, or (peak loads, retained volumes: each layout builds
// other structures) one field of every structure, each cell listing the structures the layout has.
struct Column {
  int group = 0;
  std::string heading;
  std::vector<std::string> metrics;
};

std::vector<Column> table_columns(const std::vector<std::string>& decision, const DecisionMetrics& d) {
  std::vector<Column> out;
  std::map<std::pair<int, int>, size_t> merged;  // (group, field) -> column
  for (const auto& name : decision) {
    const DecisionRank r = *d.rank(name);
    if (r.group == 3 || r.group == 4) {
      const auto key = std::make_pair(r.group, r.field);
      if (!merged.count(key)) {
        merged[key] = out.size();
        std::string h = metric_heading(d, name);
        out.push_back({r.group, h.substr(r.subject.size() + 1), {}});
      }
      out[merged[key]].metrics.push_back(name);
    } else {
      out.push_back({r.group, metric_heading(d, name), {name}});
    }
  }
  return out;
}

// One value of a cell (with the structure's name in a merged column) and its difference from the baseline.
std::string cell_value(const Layout& l, const Layout& base, const std::string& name, const std::string& subject) {
  const double v = *metric(l, name);
  std::ostringstream s;
  s << "<span data-metric=\"" << html_escape(name) << "\" data-value=\"" << exact(v) << "\">"
    << (subject.empty() ? "" : "<b>" + html_escape(subject) + "</b> ") << (means_never(name, v) ? "never" : fmt(v))
    << "</span>";
  const auto b = metric(base, name);
  if (!l.baseline && b && *b != 0 && !means_never(name, v) && !means_never(name, *b)) {  // a per cent of "never" means nothing
    const double pct = (v - *b) / std::abs(*b) * 100;
    const bool better = DecisionMetrics::higher_is_better(name) ? pct > 0 : pct < 0;
    s << " <small class=\"" << (pct == 0 ? "same" : better ? "better" : "worse") << "\">" << fmt(pct, "%+.1f %%")
      << "</small>";
  }
  return s.str();
}

std::string ranking_table(const std::vector<Layout>& layouts, const DecisionMetrics& d) {
  const std::vector<Column> columns = table_columns(decision_columns(layouts, d), d);
  const std::string key = d.outlet().empty() ? "" : "monitors.section." + d.outlet() + ".peak_discharge_m3_s";
  const Layout* base = nullptr;
  for (const auto& l : layouts)
    if (l.baseline) base = &l;
  std::ostringstream s;
  s << "<p class=\"key\">Ranked by " << (key.empty() ? "name (no section monitor: no outlet discharge to rank by)"
                                                      : "the outlet's peak discharge Q_m (<code>" + html_escape(key) +
                                                            "</code>), lowest first: the most protective layout first")
    << ". Each cell: the layout's value and its difference from the baseline " << html_escape(base->run.label)
    << " in per cent (green where it improves on the baseline, red where it is worse); – where the layout has no "
       "such metric. Layouts whose Q_m reads the same here tie: they share a rank and go by name. Peak loads and "
       "retained volumes list the structures the layout builds. <b>retained</b>: the flow volume the structure "
       "holds at the end (inside a deposition area; inside a basin below its rim; upstream of a check dam's axis "
       "below its crest); <b>upstream</b> (check dams): everything upstream of the dam's axis within its span at "
       "any height, the deposit it holds back, which on a steep bed stands mostly above the crest (so a dam can "
       "retain 0 with a volume upstream). \"never\": the flow did not reach the zone. Hover a heading for the "
       "stored metric's name.</p>";
  if (columns.empty())  // still the layouts, by name: the page says what was compared
    s << "<p class=\"note\">No decision metric is stored for these runs (no section, structure or terrain).</p>";
  s << "<div class=\"scroll\"><table id=\"ranking\" class=\"ranking\"><thead><tr><th rowspan=\"2\">#</th>"
       "<th rowspan=\"2\">layout</th>";
  for (size_t c = 0; c < columns.size();) {  // group headings spanning their columns
    size_t e = c;
    while (e < columns.size() && std::string(group_name(columns[e].group)) == group_name(columns[c].group)) ++e;
    s << "<th colspan=\"" << e - c << "\" class=\"group\">" << group_name(columns[c].group) << "</th>";
    c = e;
  }
  s << "</tr><tr>";
  for (const auto& c : columns) {
    std::string names;
    for (const auto& m : c.metrics) names += (names.empty() ? "" : "\n") + m;
    s << "<th title=\"" << html_escape(names) << "\">" << html_escape(c.heading) << "</th>";
  }
  s << "</tr></thead><tbody>";
  int rank = 0, position = 0;
  const Layout* previous = nullptr;
  for (const Layout* l : ranked(layouts, key)) {
    ++position;  // a tie shares the rank of the first of its group (1, 1, 3)
    const auto q = metric(*l, key), pq = previous ? metric(*previous, key) : std::nullopt;
    if (!(q && pq && ties(*q, *pq))) rank = position;
    previous = l;
    s << "<tr" << (l->baseline ? " class=\"baseline\"" : "") << "><td>" << rank << "</td><th scope=\"row\">"
      << "<a href=\"#layout-" << html_escape(l->run.label) << "\">" << html_escape(l->run.label) << "</a>"
      << (l->baseline ? " <small>baseline</small>" : "") << "</th>";
    for (const auto& c : columns) {
      std::string cell;
      for (const auto& m : c.metrics)
        if (metric(*l, m)) {
          const std::string subject = c.group == 3 || c.group == 4 ? d.rank(m)->subject : "";
          cell += (cell.empty() ? "" : "<br>") + cell_value(*l, *base, m, subject);
        }
      s << (cell.empty() ? "<td class=\"missing\">–</td>" : "<td>" + cell + "</td>");
    }
    s << "</tr>";
  }
  s << "</tbody></table></div>";
  return s.str();
}

// ---- maps --------------------------------------------------------------------------------------------------

// The colour of a depth on flat ground as write_depth_map_png draws it (its ramp at a hillshade of 180/255,
// which is what a level cell gets with the sun at 45 degrees).
std::string depth_colour(double t) {
  const double light[3] = {198, 225, 255}, dark[3] = {8, 40, 150}, s = 180.0 / 255.0, grey = 50 + 205 * s;
  char b[8];
  int c[3];
  for (int k = 0; k < 3; ++k)
    c[k] = static_cast<int>(std::lround(0.8 * (light[k] + t * (dark[k] - light[k])) * (0.75 + 0.5 * (s - 0.5)) + 0.2 * grey));
  std::snprintf(b, sizeof b, "#%02x%02x%02x", c[0], c[1], c[2]);
  return b;
}

// The depth legend (threshold to the run's largest depth, in m) and the keys of the outlines the PNG draws.
std::string map_legend(double lo, double hi, const std::string& id) {
  std::ostringstream s;
  s << "<svg class=\"legend\" viewBox=\"0 0 560 58\" role=\"img\" aria-label=\"legend\"><defs><linearGradient id=\"g-"
    << id << "\">";
  for (int k = 0; k <= 4; ++k) s << "<stop offset=\"" << k * 25 << "%\" stop-color=\"" << depth_colour(k / 4.0) << "\"/>";
  s << "</linearGradient></defs><text x=\"0\" y=\"12\">maximum flow depth [m] (this run's range)</text><rect x=\"0\" y=\"18\" width=\"240\" "
       "height=\"14\" fill=\"url(#g-"
    << id << ")\" stroke=\"#555\"/>";
  for (int k = 0; k <= 2; ++k)
    s << "<text x=\"" << 120 * k << "\" y=\"46\" text-anchor=\"" << (k == 0 ? "start" : k == 2 ? "end" : "middle")
      << "\">" << fmt(lo + (hi - lo) * k / 2.0, "%.2g") << "</text>";
  const char* keys[][2] = {{"#141414", "structure"}, {"#dc2828", "protected zone"}, {"#f0a000", "release"}};
  for (int k = 0; k < 3; ++k)
    s << "<line x1=\"" << 300 << "\" x2=\"" << 324 << "\" y1=\"" << 12 + 16 * k << "\" y2=\"" << 12 + 16 * k
      << "\" stroke=\"" << keys[k][0] << "\" stroke-width=\"3\"/><text x=\"330\" y=\"" << 16 + 16 * k << "\">" << keys[k][1]
      << "</text>";
  s << "<text x=\"440\" y=\"16\">grey: hillshaded</text><text x=\"440\" y=\"32\">terrain, north up</text></svg>";
  return s.str();
}

// A length of 1, 2 or 5 x 10^k metres, about a fifth of the map's width.
double scale_length(double width_m) {
  const double raw = width_m / 5, mag = std::pow(10.0, std::floor(std::log10(raw)));
  return raw / mag >= 5 ? 5 * mag : raw / mag >= 2 ? 2 * mag : mag;
}

// The run's max_depth.png as a data: URI with, over it, the names of its structures and protected zones and a
// scale bar (an SVG in the PNG's pixels), and the legend below.
std::string map_figure(const Layout& l) {
  const fs::path png = l.run.out_dir / "rasters" / "max_depth.png";
  std::optional<MapExtent> ext;
  try {
    if (!l.run.out_dir.empty() && fs::is_regular_file(png)) ext = run_map_extent(l.run.out_dir);
  } catch (const std::exception&) {
  }
  if (!ext) return "<p class=\"note\">No map: the run's folder holds no rasters/max_depth.png (a scene without "
                    "terrain, or the outputs are not where the report looked).</p>";
  const int f = terrain::depth_map_png_scale(ext->nx, ext->ny);
  const double W = ext->nx * f, H = ext->ny * f, fs_px = std::max(W, H) / 50;
  auto px = [&](double x) { return (x - ext->west) / ext->dx * f; };
  auto py = [&](double y) { return (ext->north - y) / ext->dy * f; };
  std::ostringstream s;
  s << "<figure class=\"map\"><div class=\"mapbox\"><img alt=\"maximum flow depth of " << html_escape(l.run.label)
    << "\" src=\"data:image/png;base64," << base64_encode(read_bytes(png)) << "\"><svg viewBox=\"0 0 " << W << ' ' << H
    << "\" preserveAspectRatio=\"none\" style=\"font-size:" << fs_px << "px\">";
  try {  // names over the outlines the PNG draws; a scene whose geometry cannot be read again shows none
    const SceneMap m = scene_map(l.manifest.at("scene").dump());
    // Structures named at their middle; zones (which nest: the flume's Village lies in its Plain) inside their
    // north-west corner.
    auto label = [&](const MapFeature& feat, const char* cls) {
      if (feat.points.empty()) return;
      double x = 0, y = 0, west = 1e300, north = -1e300;
      for (const auto& p : feat.points) x += p[0], y += p[1], west = std::min(west, p[0]), north = std::max(north, p[1]);
      const double n = static_cast<double>(feat.points.size());
      const bool zone = std::string(cls) == "zone";
      s << "<text class=\"" << cls << "\" x=\"" << (zone ? px(west) + 0.4 * fs_px : px(x / n)) << "\" y=\""
        << (zone ? py(north) + 1.2 * fs_px : py(y / n)) << "\"" << (zone ? "" : " text-anchor=\"middle\"") << ">"
        << html_escape(feat.name) << "</text>";
    };
    for (const auto& st : m.structures) label(st, "st");
    for (const auto& z : m.protected_zones) label(z, "zone");
  } catch (const std::exception&) {
  }
  const double len = scale_length(ext->east - ext->west), bar = len / ext->dx * f, x0 = fs_px, y0 = H - 1.6 * fs_px;
  s << "<rect x=\"" << x0 - fs_px / 2 << "\" y=\"" << y0 - 1.6 * fs_px << "\" width=\"" << bar + fs_px << "\" height=\""
    << 2.3 * fs_px << "\" fill=\"#fff\" fill-opacity=\"0.8\"/><rect class=\"scalebar\" data-metres=\"" << exact(len)
    << "\" x=\"" << x0 << "\" y=\"" << y0 << "\" width=\"" << bar << "\" height=\"" << fs_px / 3
    << "\" fill=\"#000\"/><text x=\"" << x0 + bar / 2 << "\" y=\"" << y0 - fs_px / 3 << "\" text-anchor=\"middle\">"
    << fmt(len, "%g") << " m</text></svg></div><figcaption>"
    << map_legend(metric(l, "terrain.inundation.threshold_m").value_or(0),
                  metric(l, "terrain.inundation.max_depth_m").value_or(0), html_escape(l.run.label))
    << "<br>" << fmt(ext->east - ext->west, "%.4g") << " m × " << fmt(ext->north - ext->south, "%.4g") << " m, cells of "
    << fmt(ext->dx, "%g") << " m, " << html_escape(ext->crs.empty() ? std::string("local coordinates") : ext->crs)
    << "</figcaption></figure>";
  return s.str();
}

// A legend of a colour scale: a swatch per class, or the ramp as a gradient with its end and middle labels.
std::string scale_legend(const ColourScale& sc, const std::string& id) {
  std::ostringstream s;
  s << "<svg class=\"legend\" viewBox=\"0 0 560 40\" role=\"img\" aria-label=\"legend\"><text x=\"0\" y=\"12\">"
    << html_escape(sc.title) << (sc.classes ? "" : " [" + html_escape(sc.unit) + "]") << "</text>";
  if (sc.classes) {
    for (size_t k = 0; k < sc.stops.size(); ++k)
      s << "<rect x=\"" << 90 * k << "\" y=\"18\" width=\"14\" height=\"14\" fill=\"" << sc.stops[k].colour
        << "\" stroke=\"#555\"/><text x=\"" << 90 * k + 20 << "\" y=\"30\">" << html_escape(sc.stops[k].label) << "</text>";
  } else {
    s << "<defs><linearGradient id=\"g-" << id << "\">";
    for (const auto& st : sc.stops)
      s << "<stop offset=\"" << fmt(100 * (st.value - sc.min) / (sc.max > sc.min ? sc.max - sc.min : 1), "%.1f")
        << "%\" stop-color=\"" << st.colour << "\"/>";
    s << "</linearGradient></defs><rect x=\"0\" y=\"18\" width=\"240\" height=\"10\" fill=\"url(#g-" << id
      << ")\" stroke=\"#555\"/>";
    const size_t mid = sc.stops.size() / 2;
    s << "<text x=\"0\" y=\"40\">" << html_escape(sc.stops.front().label) << "</text><text x=\"120\" y=\"40\" "
      << "text-anchor=\"middle\">" << html_escape(sc.stops[mid].label) << "</text><text x=\"240\" y=\"40\" "
      << "text-anchor=\"end\">" << html_escape(sc.stops.back().label) << "</text>";
  }
  s << "</svg>";
  return s.str();
}

// The run's intensity classes over its hillshade (the same window) and the sweep's difference rasters of this
// layout (their window is the union with the baseline's, so on their own, grey where dry in both), each with
// its legend; nothing for a run without them.
std::string hazard_maps(const Layout& l) {
  if (l.run.out_dir.empty()) return "";
  std::ostringstream s;
  const std::string id = html_escape(l.run.label);
  try {
    if (const auto p = render_run_raster(l.run.out_dir, "intensity")) {
      const fs::path hill = run_hillshade(l.run.out_dir);
      s << "<figure class=\"map hazard\" data-raster=\"intensity\"><div class=\"mapbox\">";
      if (fs::is_regular_file(hill))
        s << "<img alt=\"terrain of " << id << "\" src=\"data:image/png;base64," << base64_encode(read_bytes(hill)) << "\">";
      s << "<img class=\"over\" alt=\"intensity classes of " << id << "\" src=\"data:image/png;base64,"
        << base64_encode(p->png) << "\"></div><figcaption>" << scale_legend(p->scale, "int-" + id)
        << "<br>debris-flow intensity from the maximum depth and h·v (rasters/intensity.tif)</figcaption></figure>";
    }
    for (const char* name : {"max_depth", "max_hv"})
      if (const auto p = render_difference_raster(l.run.differences_dir.empty() ? l.run.out_dir : l.run.differences_dir, name))
        s << "<figure class=\"map hazard\" data-raster=\"diff_" << name << "\"><div class=\"mapbox diff\"><img alt=\""
          << html_escape(p->scale.title) << " (" << id << ")\" src=\"data:image/png;base64," << base64_encode(p->png)
          << "\"></div><figcaption>" << scale_legend(p->scale, std::string("diff-") + name + "-" + id)
          << "<br>this layout minus the sweep's baseline (its first layout), rasters/diff_" << name
          << ".tif; grey: dry in both</figcaption></figure>";
  } catch (const std::exception& e) {  // an unreadable raster: said, the rest of the report still written
    s << "<p class=\"note\">A hazard raster of this run could not be read: " << html_escape(e.what()) << "</p>";
  }
  return s.str();
}

// ---- fidelity and convergence -----------------------------------------------------------------------------

// The scene a run of a sweep is a layout of: its stored scene name before the variant ("flume" of "flume/C3").
std::string base_scene(const std::string& scene) { return scene.substr(0, scene.find('/')); }

struct Ladder {
  std::string sweep, scene;  // "tradeoff:flume-C0-C7/C6", "flume/C6"
  TradeoffResult result;
};

// The tradeoff ladders stored for the scene of these layouts (runout tradeoff stores each level as a run of
// sweep "tradeoff:<name>", variant "dp=<dp>[ <option>]"), each analysed as `runout tradeoff` analyses it.
std::vector<Ladder> stored_ladders(const RunStore& store, const std::vector<Layout>& layouts) {
  std::set<std::string> scenes;
  for (const auto& l : layouts) scenes.insert(base_scene(l.row.scene));
  std::map<std::string, std::map<std::string, RunStore::RunRow>> by_sweep;  // latest completed run per level
  for (const auto& r : store.list_runs())
    if (r.sweep.rfind("tradeoff:", 0) == 0 && r.status == "completed" && scenes.count(base_scene(r.scene)) &&
        r.variant.rfind("dp=", 0) == 0)
      by_sweep[r.sweep][r.variant] = r;
  std::vector<Ladder> out;
  for (const auto& [sweep, levels] : by_sweep) {
    Ladder ladder{sweep, levels.begin()->second.scene, {}};
    for (const auto& [label, row] : levels) {
      TradeoffLevel L;
      L.label = label;
      const size_t space = label.find(' ');
      L.dp = std::strtod(label.c_str() + 3, nullptr);
      if (space != std::string::npos) L.option = label.substr(space + 1);
      L.run_id = row.id;
      L.status = row.status;
      L.metrics = store.metrics(row.id);
      if (L.dp > 0) ladder.result.levels.push_back(std::move(L));
    }
    std::stable_sort(ladder.result.levels.begin(), ladder.result.levels.end(), [](const auto& a, const auto& b) {
      if (a.option.empty() != b.option.empty()) return a.option.empty();
      return a.dp > b.dp;  // the ladder from coarse to fine, then the options
    });
    analyse_tradeoff(ladder.result);
    out.push_back(std::move(ladder));
  }
  return out;
}

std::string dp_text(const std::optional<double>& dp) { return dp ? "dp " + fmt(*dp, "%g") + " m" : "none"; }

// Per decision metric, what each stored ladder says of it: the deviation from its finest rung at the report's
// dp, the coarsest dp within 5 % and 10 %, the observed order.
std::string convergence(const RunStore& store, const std::vector<Layout>& layouts, const DecisionMetrics& d,
                        double report_dp) {
  const std::vector<Ladder> ladders = stored_ladders(store, layouts);
  const std::vector<std::string> columns = decision_columns(layouts, d);
  std::ostringstream s;
  if (ladders.empty())
    return "<p class=\"note\" id=\"no-ladder\">No ladder run for this scene: the store holds no <code>runout "
           "tradeoff</code> levels of " +
           html_escape(base_scene(layouts.front().row.scene)) +
           ", so nothing here says how far these decision metrics are from their converged values. <code>runout "
           "tradeoff SWEEP.json --variant " +
           html_escape(layouts.front().run.label) + " --db …</code> stores one (docs/tradeoff.md).</p>";
  for (const Ladder& ladder : ladders) {
    const auto& levels = ladder.result.levels;
    double finest = 0;
    std::string dps;
    for (const auto& L : levels)
      if (L.option.empty()) finest = finest == 0 ? L.dp : std::min(finest, L.dp), dps += (dps.empty() ? "" : ", ") + fmt(L.dp, "%g");
    size_t at = levels.size();  // the rung at the report's dp
    for (size_t k = 0; k < levels.size(); ++k)
      if (levels[k].option.empty() && std::abs(levels[k].dp - report_dp) <= 1e-9 * report_dp) at = k;
    s << "<h3>Ladder <code>" << html_escape(ladder.sweep) << "</code> (" << html_escape(ladder.scene)
      << "): dp " << dps << " m</h3><table class=\"conv\"><thead><tr><th>decision metric</th><th>finest value (dp "
      << fmt(finest, "%g") << " m)</th><th>deviation at dp " << fmt(report_dp, "%g")
      << " m</th><th>coarsest dp within 5 %</th><th>within 10 %</th><th>observed order</th><th>what it says</th></tr></thead><tbody>";
    for (const auto& c : columns) {
      const auto it = std::find_if(ladder.result.metrics.begin(), ladder.result.metrics.end(),
                                   [&](const TradeoffMetric& m) { return m.name == c; });
      s << "<tr><th title=\"" << html_escape(c) << "\">" << html_escape(metric_heading(d, c)) << "</th>";
      if (it == ladder.result.metrics.end()) {
        s << "<td colspan=\"6\" class=\"missing\">not in this ladder (its layout lacks it, or it is −1: never)</td></tr>";
        continue;
      }
      std::string dev = "no rung at this dp";
      if (at < levels.size()) dev = it->deviation_percent[at] ? fmt(*it->deviation_percent[at], "%+.1f %%") : "–";
      std::string says;
      if (it->dp_within_5 && *it->dp_within_5 >= report_dp - 1e-12) says = "converged to 5 % at this dp";
      else if (it->dp_within_10 && *it->dp_within_10 >= report_dp - 1e-12) says = "within 10 % at this dp, not 5 %";
      else if (it->dp_within_10 && *it->dp_within_10 > finest * (1 + 1e-9))
        says = "needs dp ≤ " + fmt(*it->dp_within_10, "%g") + " m for 10 %";
      else says = "not converged on this ladder (only its finest rung is within 10 %)";
      s << "<td>" << fmt(it->finest) << "</td><td>"
        << dev << "</td><td>"
        << dp_text(it->dp_within_5) << "</td><td>" << dp_text(it->dp_within_10) << "</td><td>"
        << (it->order ? fmt(*it->order, "%.2f") : "–") << "</td><td>" << says << "</td></tr>";
    }
    s << "</tbody></table>";
  }
  return s.str();
}

std::string fidelity_table(const std::vector<Layout>& layouts) {
  std::ostringstream s;
  s << "<table class=\"plain\"><thead><tr><th>layout</th><th>fidelity</th><th>dp [m]</th><th>flow particles</th>"
       "<th>steps</th><th>simulated [s]</th><th>wall time [s]</th><th>status</th></tr></thead><tbody>";
  for (const auto& l : layouts) {
    auto v = [&](const char* name, const char* f) {
      const auto x = metric(l, name);
      return x ? fmt(*x, f) : std::string("–");
    };
    s << "<tr><th>" << html_escape(l.run.label) << "</th><td>" << html_escape(l.row.fidelity) << "</td><td>"
      << v("settings.dp_m", "%g") << "</td><td>" << v("particles.fluid_initial", "%.0f") << "</td><td>"
      << v("steps", "%.0f") << "</td><td>" << v("simulated_time_s", "%.3g") << "</td><td>" << v("wall_time_s", "%.1f")
      << "</td><td>" << html_escape(l.row.status) << "</td></tr>";
  }
  s << "</tbody></table>";
  return s.str();
}

// ---- layouts and manifests ---------------------------------------------------------------------------------

std::string structures_built(const Layout& l) {
  std::string out;
  const json& scene = l.manifest.contains("scene") ? l.manifest["scene"] : json::object();
  if (scene.contains("structures") && scene["structures"].is_array())
    for (const auto& st : scene["structures"])
      if (st.is_object() && st.contains("name") && st["name"].is_string())
        out += (out.empty() ? "" : ", ") + st["name"].get<std::string>();
  return out.empty() ? "nothing built" : out;
}

std::string layout_section(const Layout& l, const DecisionMetrics& d) {
  std::ostringstream s;
  s << "<section class=\"layout\" id=\"layout-" << html_escape(l.run.label) << "\"><h3><span class=\"swatch\" style=\"background:"
    << l.colour << "\"></span>" << html_escape(l.run.label) << (l.baseline ? " (baseline)" : "") << ": "
    << html_escape(structures_built(l)) << "</h3><p>Run " << l.run.run_id << ", " << html_escape(l.row.status)
    << ", stored " << html_escape(l.row.created_at) << ".";
  const std::string key = "monitors.section." + d.outlet() + ".peak_discharge_m3_s";
  if (const auto q = metric(l, key)) s << " Outlet Q_m " << fmt(*q) << " m³/s.";
  if (const auto a = metric(l, "terrain.inundation.inundated_area_m2")) s << " Inundated " << fmt(*a) << " m².";
  s << "</p>" << map_figure(l) << hazard_maps(l) << "</section>";
  return s.str();
}

std::string manifests(const std::vector<Layout>& layouts) {
  std::ostringstream s;
  for (const auto& l : layouts) {
    auto field = [&](const char* k) {
      return l.manifest.contains(k) && l.manifest[k].is_string() ? l.manifest[k].get<std::string>() : std::string("–");
    };
    s << "<details class=\"manifest\"><summary>" << html_escape(l.run.label) << ": run " << l.run.run_id << ", manifest "
      << html_escape(l.row.manifest_hash.substr(0, 12)) << "…</summary><table class=\"plain\"><tr><th>manifest hash</th><td><code>"
      << html_escape(l.row.manifest_hash) << "</code></td></tr><tr><th>version</th><td>" << html_escape(field("version"))
      << "</td></tr><tr><th>DEM SHA-256</th><td><code>" << html_escape(field("dem_sha256"))
      << "</code></td></tr><tr><th>fidelity</th><td>" << html_escape(field("fidelity")) << "</td></tr><tr><th>scene</th><td>"
      << html_escape(l.row.scene) << "</td></tr><tr><th>stored</th><td>" << html_escape(l.row.created_at)
      << "</td></tr></table><details><summary>the manifest as stored (JSON)</summary><pre>" << html_escape(l.manifest.dump(2))
      << "</pre></details></details>";
  }
  return s.str();
}

const char* kStyle = R"(
body{font:14px/1.45 system-ui,-apple-system,"Segoe UI",Roboto,sans-serif;color:#1d1d1f;margin:0 auto;max-width:1240px;padding:0 24px 48px}
h1{font-size:26px;margin:24px 0 4px}h2{font-size:20px;margin:36px 0 8px;border-bottom:2px solid #d0d4da;padding-bottom:4px}
h3{font-size:16px;margin:22px 0 6px}code{font-size:12px;background:#f2f3f5;padding:1px 3px;border-radius:3px}
nav a{margin-right:14px}.key,.note{color:#444;max-width:980px}.scroll{overflow-x:auto}
table{border-collapse:collapse;font-variant-numeric:tabular-nums}th,td{padding:4px 6px;border-bottom:1px solid #e3e5e8;text-align:right;vertical-align:top}
thead th{background:#f5f6f8;font-weight:600;font-size:12px;vertical-align:bottom}th.group{text-align:center;border-left:1px solid #fff;text-transform:uppercase;letter-spacing:.04em;color:#555}
tbody th{text-align:left;white-space:nowrap}.ranking{font-size:12.5px}.ranking th,.ranking td{padding:3px 4px}.ranking td small{font-size:11px;display:block;white-space:nowrap}.ranking td span{white-space:nowrap}.better{color:#1a7f37}.worse{color:#b3261e}.same{color:#666}
tr.baseline{background:#fff8e0}.missing{color:#aaa;text-align:center}table.plain th{text-align:left}
table.conv th:first-child,table.conv td:last-child,table.conv th:last-child{text-align:left}table.conv td{white-space:nowrap}table.conv td:last-child{white-space:normal}.charts{display:grid;grid-template-columns:repeat(auto-fill,minmax(560px,1fr));gap:12px}
figure{margin:8px 0}svg.chart{width:100%;height:auto;font-size:11px;fill:#333}svg.chart .ct{font-size:13px;font-weight:600}
svg.chart .plot{fill:#fff;stroke:#888}svg.chart .grid{stroke:#e6e6e6}svg.chart polyline{fill:none;stroke-width:1.6}
.layouts{display:grid;grid-template-columns:repeat(auto-fill,minmax(560px,1fr));gap:8px 24px}
.mapbox{position:relative;line-height:0;border:1px solid #bbb}.mapbox img{width:100%;height:auto;image-rendering:pixelated}
.mapbox svg{position:absolute;inset:0;width:100%;height:100%}.mapbox img.over{position:absolute;inset:0;height:100%}
.mapbox.diff{background:#d9d9d9}.mapbox text{paint-order:stroke;stroke:#fff;stroke-width:.25em;fill:#111;font-family:sans-serif}
.mapbox text.zone{fill:#b01818}svg.legend{width:100%;max-width:560px;font-size:12px;fill:#333}figcaption{font-size:12px;color:#555}
.swatch{display:inline-block;width:12px;height:12px;margin-right:6px;border-radius:2px}details.manifest{margin:4px 0}
pre{font-size:11px;background:#f7f7f9;padding:8px;overflow:auto;max-height:360px}svg.chart .zero{stroke:#555;stroke-width:1}
@media print{body{max-width:none;padding:0;font-size:10pt}nav{display:none}h2{break-after:avoid}
.scroll{overflow:visible}.ranking{font-size:8pt}.charts,.layouts{display:block}figure,tr,.layout{break-inside:avoid}
.mapbox img{image-rendering:auto}pre{max-height:none;overflow:visible;white-space:pre-wrap}
a{color:inherit;text-decoration:none}*{-webkit-print-color-adjust:exact;print-color-adjust:exact}}
)";

// ---- ensemble ----------------------------------------------------------------------------------------------

// Each layout's share of first places and its decision metrics' median with the p10-p90 band.
std::string ensemble_table(const EnsembleSummary& e) {
  const DecisionMetrics d(e.metrics);
  std::ostringstream s;
  s << "<table class=\"ensemble\"><thead><tr><th>layout</th><th>first in</th>";
  for (const auto& m : e.metrics) s << "<th>" << html_escape(d.label(m)) << "</th>";
  s << "</tr></thead><tbody>";
  for (const auto& l : e.layouts) {
    s << "<tr><th>" << html_escape(l) << "</th><td>" << fmt(100.0 * e.first_share.at(l), "%.0f") << " %</td>";
    for (const auto& m : e.metrics) {
      const auto q = e.quantiles.find(l);
      if (q == e.quantiles.end() || !q->second.count(m)) {
        s << "<td>-</td>";
        continue;
      }
      const MetricQuantiles& v = q->second.at(m);
      s << "<td>";
      if (v.count) s << "<b>" << fmt(v.p50) << "</b> (" << fmt(v.p10) << "–" << fmt(v.p90) << ")";
      if (v.never) s << (v.count ? "<br>" : "") << "never in " << v.never;
      s << "</td>";
    }
    s << "</tr>";
  }
  return s.str() + "</tbody></table>";
}

// The exceedance maps of one layout that the report shows: the intensity classes and the pressures (the depth
// and h v maps are in the folder too).
std::string exceedance_figures(const std::string& layout, const fs::path& dir) {
  std::ostringstream s;
  if (!fs::is_directory(dir)) return "";
  std::vector<fs::path> files;
  for (const auto& f : fs::directory_iterator(dir)) {
    const std::string n = f.path().filename().string();
    if (f.path().extension() == ".tif" && (n.rfind("p_intensity_", 0) == 0 || n.rfind("p_max_pressure_", 0) == 0))
      files.push_back(f.path());
  }
  std::sort(files.begin(), files.end(), [](const fs::path& a, const fs::path& b) {
    return natural_less(a.filename().string(), b.filename().string());
  });
  for (const auto& f : files) {
    const auto p = render_exceedance_raster(f);
    if (!p) continue;
    const std::string id = html_escape(layout + "-" + f.stem().string());
    s << "<figure class=\"map hazard\" data-raster=\"" << html_escape(f.stem().string()) << "\"><div class=\"mapbox\">"
      << "<img alt=\"" << html_escape(p->scale.title) << " (" << html_escape(layout) << ")\" src=\"data:image/png;base64,"
      << base64_encode(p->png) << "\"></div><figcaption>" << scale_legend(p->scale, id) << "<br>" << html_escape(layout)
      << ": exceedance/" << html_escape(f.filename().string()) << "</figcaption></figure>";
  }
  return s.str();
}

std::string ensemble_section(const StudyReportInput& in) {
  if (!in.ensemble) return "";
  const EnsembleSummary& e = *in.ensemble;
  const DecisionMetrics d(e.metrics);
  std::ostringstream s;
  s << "<section id=\"ensemble\"><h2>Ensemble: " << e.members << " members</h2><p class=\"key\">Each layout over "
    << "the members with every layout completed" << (e.incomplete ? " (" + std::to_string(e.incomplete) + " more left out)" : "")
    << ": the share of members in which it ranks first";
  if (!e.ranking_metric.empty()) s << " (lowest " << html_escape(d.label(e.ranking_metric)) << ", ties as printed shared)";
  s << ", and each decision metric's median with its p10–p90 band in brackets. The sections below show member "
    << in.member << "'s runs.</p>" << ensemble_table(e) << "<h3>Exceedance maps</h3><p class=\"key\">The share of "
    << "members whose raster reaches each threshold (output.intensity's classes; the ensemble's pressure "
       "thresholds), cell by cell; transparent where no member reaches it.</p><div class=\"layouts\">";
  for (const auto& l : e.layouts) {
    const auto it = in.exceedance_dirs.find(l);
    const std::string figs = it == in.exceedance_dirs.end() ? "" : exceedance_figures(l, it->second);
    if (!figs.empty()) s << "<div class=\"layout\"><h3>" << html_escape(l) << "</h3>" << figs << "</div>";
  }
  return s.str() + "</div></section>";
}

std::string utc_now() {
  char b[32];
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&t, &tm);
  std::strftime(b, sizeof b, "%Y-%m-%d %H:%M UTC", &tm);
  return b;
}

}  // namespace

std::string study_report_html(const RunStore& store, const StudyReportInput& input) {
  if (input.runs.empty()) throw std::invalid_argument("report: no runs to report on");
  std::vector<Layout> layouts;
  std::vector<std::string> names;
  for (const auto& r : input.runs) {
    Layout l{r, {}, store.metrics(r.run_id), json::parse(store.manifest_json(r.run_id), nullptr, false),
             r.run_id == input.baseline_id, ""};
    l.row = *store.get_run(r.run_id);
    if (l.run.label.empty()) l.run.label = l.row.variant.empty() ? "#" + std::to_string(r.run_id) : l.row.variant;
    if (!l.manifest.is_object()) l.manifest = json::object();
    for (const auto& [n, v] : l.metrics) names.push_back(n);
    layouts.push_back(std::move(l));
  }
  const auto base = std::find_if(layouts.begin(), layouts.end(), [](const Layout& l) { return l.baseline; });
  if (base == layouts.end())
    throw std::invalid_argument("report: the baseline (run " + std::to_string(input.baseline_id) + ") is not one of the runs");
  size_t colour = 0;
  for (auto& l : layouts) l.colour = l.baseline ? "#222222" : layout_colour(colour++);
  const DecisionMetrics d(names);
  const double dp = metric(*base, "settings.dp_m").value_or(0);
  std::ostringstream s;
  s << "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><meta name=\"viewport\" "
       "content=\"width=device-width,initial-scale=1\"><title>Study report: "
    << html_escape(input.title) << "</title><style>" << kStyle << "</style></head><body><header><h1>Study report: "
    << html_escape(input.title) << "</h1><p>" << layouts.size() << " layouts of " << html_escape(base_scene(base->row.scene))
    << ", baseline " << html_escape(base->run.label) << ", fidelity " << html_escape(base->row.fidelity) << " (dp "
    << fmt(dp, "%g") << " m), outlet " << html_escape(d.outlet().empty() ? std::string("none") : d.outlet())
    << ". Written " << utc_now() << " by runout " << RUNOUT_VERSION
    << ".</p><nav>" << (input.ensemble ? "<a href=\"#ensemble\">Ensemble</a>" : "")
    << "<a href=\"#ranking-section\">Ranking</a><a href=\"#hydrographs\">Hydrographs</a><a href=\"#loads\">Loads</a>"
       "<a href=\"#layouts\">Layouts and maps</a><a href=\"#fidelity\">Fidelity and convergence</a><a "
       "href=\"#manifests\">Manifests</a></nav></header>";
  s << ensemble_section(input);
  s << "<section id=\"ranking-section\"><h2>Ranking of the layouts by the decision metrics</h2>" << ranking_table(layouts, d)
    << "</section>";
  const std::string hydro = monitor_charts(store, layouts, "section_", "discharge_m3_s", "discharge", "m³/s");
  const std::string loads =
      monitor_charts(store, layouts, "structure_load_", "force_n", "force along the downstream normal", "N");
  s << "<section id=\"hydrographs\"><h2>Hydrographs</h2><p class=\"key\">Discharge through each cross-section (the "
       "filtered series the peaks are taken from), one line per layout; the baseline dashed.</p><div class=\"charts\">"
    << (hydro.empty() ? "<p class=\"note\">No section monitors in these runs.</p>" : hydro) << "</div></section>";
  s << "<section id=\"loads\"><h2>Loads on the structures</h2><p class=\"key\">Force on each structure's load cell "
       "(window means), one line per layout that builds it. Sign: the force's component along the structure's "
       "downstream normal (the direction the flow runs through it); <b>positive</b>, the flow pushes the structure "
       "downstream, as an impact does; <b>negative</b>, the net push points upstream, from material resting "
       "against the structure's downstream face or piled on its lee after overtopping (the zero line is drawn "
       "where a load turns negative). The peak loads in the ranking are the largest positive values.</p>"
       "<div class=\"charts\">"
    << (loads.empty() ? "<p class=\"note\">No structure load monitors in these runs.</p>" : loads) << "</div></section>";
  s << "<section id=\"layouts\"><h2>Layouts and maps</h2><div class=\"layouts\">";
  for (const auto& l : layouts) s << layout_section(l, d);
  s << "</div></section><section id=\"fidelity\"><h2>Fidelity and convergence</h2>" << fidelity_table(layouts)
    << convergence(store, layouts, d, dp) << "</section><section id=\"manifests\"><h2>Run manifests</h2>"
    << manifests(layouts) << "</section></body></html>\n";
  return s.str();
}

namespace {

// The completed runs of the sweep (variant -> latest id) and, for an ensemble, those of one member relabelled by
// layout (the member chosen into `member`).
std::map<std::string, int64_t> report_variants(const RunStore& store, const std::string& sweep,
                                               const std::optional<EnsembleSummary>& ensemble, int& member) {
  std::map<std::string, int64_t> latest;
  for (const auto& r : store.list_runs(sweep))
    if (r.status == "completed") latest[r.variant] = r.id;  // by id: the last is the latest
  if (!ensemble) return latest;
  std::map<int, std::map<std::string, int64_t>> members;
  for (const auto& [v, id] : latest)
    if (const auto m = split_member_name(v)) members[m->member][m->layout] = id;
  if (member < 0)
    for (const auto& [m, layouts] : members)
      if (layouts.size() == ensemble->layouts.size()) {
        member = m;
        break;
      }
  if (member < 0 && !members.empty()) member = members.begin()->first;
  if (!members.count(member))
    throw std::invalid_argument("--member: member " + std::to_string(member) + " of sweep '" + sweep +
                                "' has no completed run");
  return members.at(member);
}

}  // namespace

StudyReportInput sweep_report_input(const RunStore& store, const std::string& sweep, const std::string& baseline,
                                    const fs::path& runs_root, int member) {
  const std::optional<EnsembleSummary> ensemble = summarise_ensemble(store, sweep);
  if (!ensemble && member >= 0)
    throw std::invalid_argument("--member: sweep '" + sweep + "' is not an ensemble");
  const std::map<std::string, int64_t> latest = report_variants(store, sweep, ensemble, member);
  if (latest.empty())
    throw std::invalid_argument("--sweep: no completed run of sweep '" + sweep + "' in " + store.path().string());
  std::vector<std::string> variants;
  for (const auto& [v, id] : latest) variants.push_back(v);
  std::sort(variants.begin(), variants.end(), natural_less);
  const std::string base = baseline.empty() ? variants.front() : baseline;
  if (!latest.count(base)) {
    std::string list;
    for (const auto& v : variants) list += (list.empty() ? "" : ", ") + v;
    throw std::invalid_argument("--baseline: '" + base + "' is not a completed " + (ensemble ? "layout" : "variant") +
                                " of sweep '" + sweep + "' (accepted: " + list + ")");
  }
  StudyReportInput in{sweep, {}, latest.at(base), ensemble, ensemble ? member : -1, {}};
  for (const auto& v : variants) {
    const std::string folder = ensemble ? store.get_run(latest.at(v))->variant : v;
    in.runs.push_back({latest.at(v), v, runs_root / sweep / folder, {}});
    if (ensemble) in.exceedance_dirs[v] = runs_root / sweep / v / "exceedance";
  }
  return in;
}

void write_study_report(const RunStore& store, const std::string& sweep, const std::string& baseline,
                        const fs::path& runs_root, const fs::path& out_path, int member) {
  const StudyReportInput input = sweep_report_input(store, sweep, baseline, runs_root, member);
  // A mistyped --runs would otherwise give a page of "No map" and exit 0.
  if (!fs::is_directory(runs_root / sweep))
    throw std::invalid_argument("--runs: no folder " + (runs_root / sweep).string() + " (runout sweep --out RUNS writes "
                                "each layout of sweep '" + sweep + "' to RUNS/" + sweep + "/<variant>)");
  const std::string html = study_report_html(store, input);
  if (out_path.has_parent_path()) fs::create_directories(out_path.parent_path());
  const fs::path tmp = out_path.string() + ".tmp";
  {
    std::ofstream out(tmp, std::ios::binary);
    out << html;
    if (!out.flush()) throw std::runtime_error("report: cannot write " + tmp.string());
  }
  fs::rename(tmp, out_path);
}

}  // namespace runout
