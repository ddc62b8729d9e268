#pragma once
// A run's state as bytes, for a checkpoint a run resumes from (the solver's, each monitor's, the caller's own):
// plain values and vectors of them, in the machine's byte order, each part opened by a label that the reader
// checks, so a checkpoint read by a build that lays it out otherwise fails with the part's name instead of
// resuming from garbage. A checkpoint is for the build that wrote it, not an exchange format.
#include <array>
#include <cstdint>
#include <istream>
#include <ostream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace runout {

class StateWriter {
 public:
  explicit StateWriter(std::ostream& out) : out_(out) {}
  // Opens a part: the reader must expect the same label here.
  void label(const std::string& name) { text(name); }
  template <class T>
  void value(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.write(reinterpret_cast<const char*>(&v), sizeof v);
  }
  template <class T>
  void values(const std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    value<uint64_t>(v.size());
    if (!v.empty()) out_.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size() * sizeof(T)));
  }
  void text(const std::string& s) {
    value<uint64_t>(s.size());
    out_.write(s.data(), static_cast<std::streamsize>(s.size()));
  }
  bool good() const { return static_cast<bool>(out_); }

 private:
  std::ostream& out_;
};

// Throws std::runtime_error naming the part on a label that does not match, a short read or a size that cannot be.
class StateReader {
 public:
  explicit StateReader(std::istream& in) : in_(in) {}
  void expect(const std::string& name) {
    const std::string got = text();
    if (got != name) throw std::runtime_error("checkpoint: expected part '" + name + "', found '" + got + "'");
    part_ = name;
  }
  template <class T>
  T value() {
    static_assert(std::is_trivially_copyable_v<T>);
    T v{};
    in_.read(reinterpret_cast<char*>(&v), sizeof v);
    if (!in_) fail("ends early");
    return v;
  }
  template <class T>
  void value(T& v) {
    v = value<T>();
  }
  template <class T>
  void values(std::vector<T>& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    const uint64_t n = value<uint64_t>();
    if (n > (uint64_t{1} << 40) / sizeof(T)) fail("holds an impossible length");
    v.resize(n);
    if (n) in_.read(reinterpret_cast<char*>(v.data()), static_cast<std::streamsize>(n * sizeof(T)));
    if (!in_) fail("ends early");
  }
  std::string text() {
    const uint64_t n = value<uint64_t>();
    if (n > (uint64_t{1} << 32)) fail("holds an impossible length");
    std::string s(n, '\0');
    in_.read(s.data(), static_cast<std::streamsize>(n));
    if (!in_) fail("ends early");
    return s;
  }
  [[noreturn]] void fail(const std::string& why) const {
    throw std::runtime_error("checkpoint" + (part_.empty() ? std::string() : " part '" + part_ + "'") + " " + why);
  }

 private:
  std::istream& in_;
  std::string part_;
};

}  // namespace runout
