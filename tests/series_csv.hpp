#pragma once
// A run's series/*.csv read back by the scene tests: a header row of names, then rows of numbers.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace runout_test {

struct Series {
  std::vector<std::string> header;
  std::vector<std::vector<double>> rows;
  // The named column, or empty when the header lacks it.
  std::vector<double> col(const std::string& name) const {
    const size_t k = static_cast<size_t>(std::find(header.begin(), header.end(), name) - header.begin());
    std::vector<double> v;
    if (k >= header.size()) return v;
    for (const auto& r : rows) v.push_back(r[k]);
    return v;
  }
};

inline Series read_csv(const std::filesystem::path& p) {
  Series s;
  std::ifstream in(p);
  std::string line, c;
  if (!std::getline(in, line)) return s;
  std::stringstream hs(line);
  while (std::getline(hs, c, ',')) s.header.push_back(c);
  while (std::getline(in, line)) {
    std::vector<double> v;
    std::stringstream ss(line);
    while (std::getline(ss, c, ',')) v.push_back(std::stod(c));
    s.rows.push_back(v);
  }
  return s;
}

}  // namespace runout_test
