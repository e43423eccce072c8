// PLY and PCD readers and writers, written by hand (no PCL in core).
//
// PLY: "ply", "format ascii|binary_little_endian|binary_big_endian 1.0", elements with scalar or list
// properties, "end_header". Only the vertex element is read (x y z, colour from red|r|diffuse_red ...,
// normal from nx ny nz);
// elements before it are skipped row by row, elements after it are not read at all.
// PCD (v0.5-0.7): header keys FIELDS SIZE TYPE COUNT WIDTH HEIGHT POINTS DATA; DATA ascii, binary or
// binary_compressed (LZF, fields stored one after the other). Colour is the packed "rgb" or "rgba",
// 0xAARRGGBB in 4 bytes (TYPE U as PCL 1.13 writes it, or TYPE F holding those bits as older files do;
// an ASCII F value may be the integer or the float); alpha is written 255 and ignored on reading.
// Checked against PCL 1.13's pcl::io readers and writers (PointXYZRGB, every encoding) both ways.
// Both writers produce x y z as float; the readers convert any numeric type to float.

#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <initializer_list>
#include <limits>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "fleetslam/core/error.hpp"
#include "fleetslam/core/point_cloud.hpp"

namespace fleetslam::core {
namespace {

namespace fs = std::filesystem;

#if defined(__BYTE_ORDER__) && __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__
constexpr bool kHostBigEndian = true;
#else
constexpr bool kHostBigEndian = false;
#endif

// ---------------------------------------------------------------------------------------------------
// Files

std::string read_whole_file(const std::string& file) {
  if (fs::is_directory(file)) throw InputError(file, "is a folder, not a point cloud file");
  std::ifstream in(file, std::ios::binary | std::ios::ate);
  if (!in) throw InputError(file, "cannot open the file");
  const std::streamoff size = in.tellg();
  if (size < 0) throw InputError(file, "cannot read the file size");
  std::string data(static_cast<std::size_t>(size), '\0');
  in.seekg(0);
  in.read(data.data(), size);
  if (in.gcount() != size) throw InputError(file, "read error");
  return data;
}

void write_whole_file(const std::string& file, const std::string& data) {
  const fs::path path(file);
  std::error_code ec;
  if (path.has_parent_path()) fs::create_directories(path.parent_path(), ec);
  if (ec) throw InputError(file, "cannot create the folder: " + ec.message());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(file, "cannot open the file for writing");
  out.write(data.data(), static_cast<std::streamsize>(data.size()));
  out.flush();
  if (!out) throw InputError(file, "write failed");
}

// ---------------------------------------------------------------------------------------------------
// Scalars shared by both formats

enum class Scalar { kI8, kU8, kI16, kU16, kI32, kU32, kI64, kU64, kF32, kF64 };

std::size_t scalar_size(Scalar type) {
  switch (type) {
    case Scalar::kI8:
    case Scalar::kU8: return 1;
    case Scalar::kI16:
    case Scalar::kU16: return 2;
    case Scalar::kI32:
    case Scalar::kU32:
    case Scalar::kF32: return 4;
    case Scalar::kI64:
    case Scalar::kU64:
    case Scalar::kF64: return 8;
  }
  return 0;
}

bool is_float(Scalar type) { return type == Scalar::kF32 || type == Scalar::kF64; }

template <class T>
T load_raw(const char* p, bool swap) {
  std::array<char, sizeof(T)> bytes;
  std::memcpy(bytes.data(), p, sizeof(T));
  if (swap) std::reverse(bytes.begin(), bytes.end());
  T value;
  std::memcpy(&value, bytes.data(), sizeof(T));
  return value;
}

double load_scalar(const char* p, Scalar type, bool swap) {
  switch (type) {
    case Scalar::kI8: return load_raw<std::int8_t>(p, false);
    case Scalar::kU8: return load_raw<std::uint8_t>(p, false);
    case Scalar::kI16: return load_raw<std::int16_t>(p, swap);
    case Scalar::kU16: return load_raw<std::uint16_t>(p, swap);
    case Scalar::kI32: return load_raw<std::int32_t>(p, swap);
    case Scalar::kU32: return load_raw<std::uint32_t>(p, swap);
    case Scalar::kI64: return static_cast<double>(load_raw<std::int64_t>(p, swap));
    case Scalar::kU64: return static_cast<double>(load_raw<std::uint64_t>(p, swap));
    case Scalar::kF32: return static_cast<double>(load_raw<float>(p, swap));
    case Scalar::kF64: return load_raw<double>(p, swap);
  }
  return 0.0;
}

template <class T>
void append_raw(std::string& out, T value) {
  std::array<char, sizeof(T)> bytes;
  std::memcpy(bytes.data(), &value, sizeof(T));
  if (kHostBigEndian) std::reverse(bytes.begin(), bytes.end());  // both formats are written little-endian
  out.append(bytes.data(), bytes.size());
}

// Shortest text that reads back to the same float (std::to_chars round-trip guarantee).
void append_number(std::string& out, float value) {
  if (std::isnan(value)) {
    out += "nan";
    return;
  }
  std::array<char, 32> buffer;
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  out.append(buffer.data(), result.ptr);
}

void append_number(std::string& out, std::uint32_t value) {
  std::array<char, 16> buffer;
  const auto result = std::to_chars(buffer.data(), buffer.data() + buffer.size(), value);
  out.append(buffer.data(), result.ptr);
}

std::uint8_t to_channel(double value, Scalar type) {
  if (std::isnan(value)) return 0;
  if (is_float(type)) value *= 255.0;  // float colours are in [0, 1]
  return static_cast<std::uint8_t>(std::clamp(std::lround(value), 0L, 255L));
}

// 0xAARRGGBB with alpha 255, as PCL's PointXYZRGB stores it.
std::uint32_t pack_rgb(const PointCloud::Rgb& rgb) {
  return 0xff000000u | (std::uint32_t{rgb[0]} << 16) | (std::uint32_t{rgb[1]} << 8) | std::uint32_t{rgb[2]};
}

PointCloud::Rgb unpack_rgb(std::uint32_t packed) {
  return {static_cast<std::uint8_t>((packed >> 16) & 0xff), static_cast<std::uint8_t>((packed >> 8) & 0xff),
          static_cast<std::uint8_t>(packed & 0xff)};
}

// ---------------------------------------------------------------------------------------------------
// Header lines and body readers

// Splits a line at blanks.
std::vector<std::string_view> split_words(std::string_view line) {
  std::vector<std::string_view> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    const std::size_t start = i;
    while (i < line.size() && !std::isspace(static_cast<unsigned char>(line[i]))) ++i;
    if (i > start) words.push_back(line.substr(start, i - start));
  }
  return words;
}

// The values an integer scalar type holds, as doubles (the 64-bit limits round up to a power of two, which
// does no harm: values are kept as doubles).
std::pair<double, double> integer_range(Scalar type) {
  switch (type) {
    case Scalar::kI8: return {-128.0, 127.0};
    case Scalar::kU8: return {0.0, 255.0};
    case Scalar::kI16: return {-32768.0, 32767.0};
    case Scalar::kU16: return {0.0, 65535.0};
    case Scalar::kI32: return {-2147483648.0, 2147483647.0};
    case Scalar::kU32: return {0.0, 4294967295.0};
    case Scalar::kI64: return {-9223372036854775808.0, 9223372036854775807.0};
    case Scalar::kU64: return {0.0, 18446744073709551615.0};
    case Scalar::kF32:
    case Scalar::kF64: break;
  }
  return {-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()};
}

template <class T>
std::optional<T> parse_number(std::string_view text) {
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  T value{};
  const auto result = std::from_chars(text.data(), text.data() + text.size(), value);
  if (result.ec != std::errc() || result.ptr != text.data() + text.size()) return std::nullopt;
  return value;
}

// A number of the given type; floats parse as float so that the shortest text of a float reads back
// bit for bit (no double rounding through double).
std::optional<double> parse_value(std::string_view text, Scalar type) {
  if (type == Scalar::kF32) {
    const std::optional<float> value = parse_number<float>(text);
    return value ? std::optional<double>(static_cast<double>(*value)) : std::nullopt;
  }
  const std::optional<double> value = parse_number<double>(text);
  if (!value || type == Scalar::kF64) return value;
  // An integer type takes whole numbers within its range ("255.0" is 255; "3.5", or 300 for a uchar, is
  // no uchar): a list count of 3.5 read three items and misaligned the rest of the row.
  const auto [lowest, highest] = integer_range(type);
  if (!(*value >= lowest && *value <= highest && std::floor(*value) == *value)) return std::nullopt;
  return value;
}

// Reads header lines one at a time, remembering where the body starts.
class HeaderLines {
 public:
  HeaderLines(const std::string& file, const std::string& data) : file_(file), data_(data) {}

  // The next line without its end-of-line; false at the end of the data.
  bool next(std::string_view& line) {
    if (pos_ >= data_.size()) return false;
    std::size_t end = data_.find('\n', pos_);
    const bool last = end == std::string::npos;
    if (last) end = data_.size();
    line = std::string_view(data_).substr(pos_, end - pos_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos_ = last ? data_.size() : end + 1;
    ++number_;
    return true;
  }
  std::size_t body_offset() const { return pos_; }
  std::string where() const { return at_line(file_, number_); }

 private:
  const std::string& file_;
  const std::string& data_;
  std::size_t pos_ = 0;
  std::size_t number_ = 0;
};

// Sequential access to a body: binary values or ASCII numbers, failing on a short body.
class BodyReader {
 public:
  BodyReader(std::string_view body, bool ascii, bool swap) : body_(body), ascii_(ascii), swap_(swap) {}

  // Next value of the given type as a double; nullopt when the body ends (or an ASCII token is bad,
  // then bad_token() names it).
  std::optional<double> next(Scalar type) {
    if (!ascii_) {
      const std::size_t n = scalar_size(type);
      if (body_.size() - pos_ < n) return std::nullopt;
      const double value = load_scalar(body_.data() + pos_, type, swap_);
      pos_ += n;
      return value;
    }
    const std::optional<std::string_view> token = next_token();
    if (!token) return std::nullopt;
    const std::optional<double> value = parse_value(*token, type);
    if (!value) bad_token_ = std::string(*token);
    return value;
  }

  std::optional<std::string_view> next_token() {
    while (pos_ < body_.size() && std::isspace(static_cast<unsigned char>(body_[pos_]))) ++pos_;
    const std::size_t start = pos_;
    while (pos_ < body_.size() && !std::isspace(static_cast<unsigned char>(body_[pos_]))) ++pos_;
    if (pos_ == start) return std::nullopt;
    return body_.substr(start, pos_ - start);
  }

  const std::string& bad_token() const { return bad_token_; }

 private:
  std::string_view body_;
  bool ascii_;
  bool swap_;
  std::size_t pos_ = 0;
  std::string bad_token_;
};

// Which properties/fields make up a point.
struct PointSlots {
  std::array<int, 3> xyz = {-1, -1, -1};
  std::array<int, 3> rgb = {-1, -1, -1};
  std::array<int, 3> normal = {-1, -1, -1};  // PLY only
  bool has_xyz() const { return xyz[0] >= 0 && xyz[1] >= 0 && xyz[2] >= 0; }
  bool has_rgb() const { return rgb[0] >= 0 && rgb[1] >= 0 && rgb[2] >= 0; }
  bool has_normal() const { return normal[0] >= 0 && normal[1] >= 0 && normal[2] >= 0; }
};

// ---------------------------------------------------------------------------------------------------
// PLY

struct PlyProperty {
  std::string name;
  Scalar type = Scalar::kF32;
  bool is_list = false;
  Scalar count_type = Scalar::kU8;
};

struct PlyElement {
  std::string name;
  std::size_t count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyFormat { kAscii, kBinaryLittle, kBinaryBig };

struct PlyHeader {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<PlyElement> elements;
  std::size_t body_offset = 0;
};

std::optional<Scalar> ply_scalar(std::string_view name) {
  static constexpr std::array<std::pair<std::string_view, Scalar>, 16> kNames = {{
      {"char", Scalar::kI8},     {"int8", Scalar::kI8},     {"uchar", Scalar::kU8},   {"uint8", Scalar::kU8},
      {"short", Scalar::kI16},   {"int16", Scalar::kI16},   {"ushort", Scalar::kU16}, {"uint16", Scalar::kU16},
      {"int", Scalar::kI32},     {"int32", Scalar::kI32},   {"uint", Scalar::kU32},   {"uint32", Scalar::kU32},
      {"float", Scalar::kF32},   {"float32", Scalar::kF32}, {"double", Scalar::kF64}, {"float64", Scalar::kF64},
  }};
  for (const auto& [text, type] : kNames) {
    if (text == name) return type;
  }
  return std::nullopt;
}

PlyHeader parse_ply_header(const std::string& file, const std::string& data) {
  HeaderLines lines(file, data);
  std::string_view line;
  if (!lines.next(line) || line != "ply") throw InputError(file, "bad header: not a PLY file (no 'ply' magic line)");
  PlyHeader header;
  bool have_format = false;
  while (true) {
    if (!lines.next(line)) throw InputError(file, "bad header: no 'end_header' line");
    const std::vector<std::string_view> words = split_words(line);
    if (words.empty() || words[0] == "comment" || words[0] == "obj_info") continue;
    const auto bad = [&](const std::string& why) { return InputError(lines.where(), "bad header: " + why); };
    if (words[0] == "end_header") break;
    if (words[0] == "format") {
      if (words.size() != 3) throw bad("expected 'format <type> 1.0'");
      if (words[1] == "ascii") {
        header.format = PlyFormat::kAscii;
      } else if (words[1] == "binary_little_endian") {
        header.format = PlyFormat::kBinaryLittle;
      } else if (words[1] == "binary_big_endian") {
        header.format = PlyFormat::kBinaryBig;
      } else {
        throw bad("unknown format '" + std::string(words[1]) + "'");
      }
      have_format = true;
    } else if (words[0] == "element") {
      const std::optional<std::size_t> count = words.size() == 3 ? parse_number<std::size_t>(words[2]) : std::nullopt;
      if (!count) throw bad("expected 'element <name> <count>'");
      header.elements.push_back(PlyElement{std::string(words[1]), *count, {}});
    } else if (words[0] == "property") {
      if (header.elements.empty()) throw bad("property before any element");
      PlyProperty property;
      if (words.size() == 5 && words[1] == "list") {
        const std::optional<Scalar> count_type = ply_scalar(words[2]);
        const std::optional<Scalar> item_type = ply_scalar(words[3]);
        if (!count_type || !item_type) throw bad("unknown list type in '" + std::string(line) + "'");
        property = PlyProperty{std::string(words[4]), *item_type, true, *count_type};
      } else if (words.size() == 3) {
        const std::optional<Scalar> type = ply_scalar(words[1]);
        if (!type) throw bad("unknown property type '" + std::string(words[1]) + "'");
        property = PlyProperty{std::string(words[2]), *type, false, Scalar::kU8};
      } else {
        throw bad("expected 'property <type> <name>' or 'property list <count type> <item type> <name>'");
      }
      header.elements.back().properties.push_back(property);
    } else {
      throw bad("unknown keyword '" + std::string(words[0]) + "'");
    }
  }
  if (!have_format) throw InputError(file, "bad header: no 'format' line");
  header.body_offset = lines.body_offset();
  return header;
}

PointSlots ply_slots(const PlyElement& vertex) {
  PointSlots slots;
  const auto find = [&](std::initializer_list<std::string_view> names) {
    for (std::size_t i = 0; i < vertex.properties.size(); ++i) {
      const PlyProperty& property = vertex.properties[i];
      if (property.is_list) continue;
      for (std::string_view name : names) {
        if (property.name == name) return static_cast<int>(i);
      }
    }
    return -1;
  };
  slots.xyz = {find({"x"}), find({"y"}), find({"z"})};
  slots.rgb = {find({"red", "r", "diffuse_red"}), find({"green", "g", "diffuse_green"}),
               find({"blue", "b", "diffuse_blue"})};
  slots.normal = {find({"nx"}), find({"ny"}), find({"nz"})};
  return slots;
}

// Reads one row of `element`; scalar values go to `values` (lists are consumed and dropped).
// False when the body ends early or holds a bad number.
bool read_ply_row(BodyReader& body, const PlyElement& element, std::vector<double>& values) {
  for (std::size_t i = 0; i < element.properties.size(); ++i) {
    const PlyProperty& property = element.properties[i];
    if (!property.is_list) {
      const std::optional<double> value = body.next(property.type);
      if (!value) return false;
      values[i] = *value;
      continue;
    }
    const std::optional<double> count = body.next(property.count_type);
    if (!count || *count < 0.0) return false;
    for (std::size_t k = 0; k < static_cast<std::size_t>(*count); ++k) {
      if (!body.next(property.type)) return false;
    }
  }
  return true;
}

std::string element_message(const PlyElement& element, std::size_t rows_read, const BodyReader& body) {
  std::string why = "truncated body: " + std::to_string(rows_read) + " of " + std::to_string(element.count) +
                    " '" + element.name + "' rows read";
  if (!body.bad_token().empty()) why = "bad number '" + body.bad_token() + "' in '" + element.name + "' row " +
                                       std::to_string(rows_read + 1);
  return why;
}

std::string ply_header_text(const PointCloud& cloud, CloudEncoding encoding) {
  std::string header = "ply\n";
  header += encoding == CloudEncoding::kAscii ? "format ascii 1.0\n" : "format binary_little_endian 1.0\n";
  header += "comment fleetslam\n";
  header += "element vertex " + std::to_string(cloud.size()) + "\n";
  header += "property float x\nproperty float y\nproperty float z\n";
  if (cloud.has_colors()) header += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  if (cloud.has_normals()) header += "property float nx\nproperty float ny\nproperty float nz\n";
  header += "end_header\n";
  return header;
}

// ---------------------------------------------------------------------------------------------------
// PCD

struct PcdField {
  std::string name;
  Scalar type = Scalar::kF32;
  std::size_t count = 1;
  std::size_t offset = 0;  // bytes into a binary point
};

enum class PcdData { kAscii, kBinary, kBinaryCompressed };

struct PcdHeader {
  std::vector<PcdField> fields;
  std::size_t point_size = 0;
  std::size_t points = 0;
  PcdData data = PcdData::kAscii;
  std::size_t body_offset = 0;
};

std::optional<Scalar> pcd_scalar(std::string_view type, std::size_t size) {
  if (type == "F") {
    if (size == 4) return Scalar::kF32;
    if (size == 8) return Scalar::kF64;
  } else if (type == "U" || type == "I") {
    const bool u = type == "U";
    switch (size) {
      case 1: return u ? Scalar::kU8 : Scalar::kI8;
      case 2: return u ? Scalar::kU16 : Scalar::kI16;
      case 4: return u ? Scalar::kU32 : Scalar::kI32;
      case 8: return u ? Scalar::kU64 : Scalar::kI64;
      default: break;
    }
  }
  return std::nullopt;
}

PcdHeader parse_pcd_header(const std::string& file, const std::string& data) {
  HeaderLines lines(file, data);
  std::string_view line;
  std::vector<std::string> names;
  std::vector<std::size_t> sizes;
  std::vector<std::string> types;
  std::vector<std::size_t> counts;
  std::optional<std::size_t> width, height, points;
  std::optional<PcdData> body;
  const auto numbers = [&](const std::vector<std::string_view>& words, const char* key) {
    std::vector<std::size_t> values;
    for (std::size_t i = 1; i < words.size(); ++i) {
      const std::optional<std::size_t> value = parse_number<std::size_t>(words[i]);
      if (!value) throw InputError(lines.where(), std::string("bad header: ") + key + " expects non-negative integers");
      values.push_back(*value);
    }
    return values;
  };
  const auto one_number = [&](const std::vector<std::string_view>& words, const char* key) {
    const std::vector<std::size_t> values = numbers(words, key);
    if (values.size() != 1) throw InputError(lines.where(), std::string("bad header: ") + key + " expects one integer");
    return values[0];
  };
  while (!body) {
    if (!lines.next(line)) throw InputError(file, "bad header: no DATA line (not a PCD file?)");
    const std::vector<std::string_view> words = split_words(line);
    if (words.empty() || words[0].front() == '#') continue;
    const std::string_view key = words[0];
    if (key == "VERSION" || key == "VIEWPOINT") continue;  // the viewpoint is not applied
    if (key == "FIELDS" || key == "COLUMNS") {
      names.assign(words.begin() + 1, words.end());
    } else if (key == "SIZE") {
      sizes = numbers(words, "SIZE");
    } else if (key == "TYPE") {
      types.assign(words.begin() + 1, words.end());
    } else if (key == "COUNT") {
      counts = numbers(words, "COUNT");
    } else if (key == "WIDTH") {
      width = one_number(words, "WIDTH");
    } else if (key == "HEIGHT") {
      height = one_number(words, "HEIGHT");
    } else if (key == "POINTS") {
      points = one_number(words, "POINTS");
    } else if (key == "DATA") {
      if (words.size() != 2) throw InputError(lines.where(), "bad header: expected 'DATA ascii|binary|binary_compressed'");
      if (words[1] == "ascii") {
        body = PcdData::kAscii;
      } else if (words[1] == "binary") {
        body = PcdData::kBinary;
      } else if (words[1] == "binary_compressed") {
        body = PcdData::kBinaryCompressed;
      } else {
        throw InputError(lines.where(), "bad header: unknown DATA '" + std::string(words[1]) + "'");
      }
    } else {
      throw InputError(lines.where(), "bad header: unknown keyword '" + std::string(key) + "'");
    }
  }
  const auto bad = [&](const std::string& why) { return InputError(file, "bad header: " + why); };
  if (names.empty()) throw bad("no FIELDS line");
  if (counts.empty()) counts.assign(names.size(), 1);
  if (sizes.size() != names.size() || types.size() != names.size() || counts.size() != names.size()) {
    throw bad("FIELDS, SIZE, TYPE and COUNT list different numbers of fields");
  }
  if (!width || !height) throw bad("missing WIDTH or HEIGHT");
  std::size_t area = 0;
  if (__builtin_mul_overflow(*width, *height, &area)) throw bad("WIDTH * HEIGHT is too large");
  if (!points) points = area;
  if (*points != area) throw bad("POINTS is not WIDTH * HEIGHT");
  PcdHeader header;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::optional<Scalar> type = pcd_scalar(types[i], sizes[i]);
    if (!type) throw bad("unsupported TYPE " + types[i] + " with SIZE " + std::to_string(sizes[i]));
    if (counts[i] == 0) throw bad("COUNT 0 for field '" + names[i] + "'");
    if (counts[i] > (1u << 20)) throw bad("COUNT " + std::to_string(counts[i]) + " of field '" + names[i] + "' is too large");
    header.fields.push_back(PcdField{names[i], *type, counts[i], header.point_size});
    header.point_size += sizes[i] * counts[i];
  }
  std::size_t body_bytes = 0;  // a body this large cannot be read anyway; this keeps later products exact
  if (__builtin_mul_overflow(*points, header.point_size, &body_bytes)) throw bad("POINTS is too large");
  header.points = *points;
  header.data = *body;
  header.body_offset = lines.body_offset();
  return header;
}

// Slots index fields; the colour slots all point at the packed rgb/rgba field.
PointSlots pcd_slots(const PcdHeader& header) {
  PointSlots slots;
  for (std::size_t i = 0; i < header.fields.size(); ++i) {
    const PcdField& field = header.fields[i];
    const int index = static_cast<int>(i);
    if (field.name == "x") slots.xyz[0] = index;
    if (field.name == "y") slots.xyz[1] = index;
    if (field.name == "z") slots.xyz[2] = index;
    if ((field.name == "rgb" || field.name == "rgba") && scalar_size(field.type) == 4 && slots.rgb[0] < 0) {
      slots.rgb = {index, index, index};
    }
  }
  return slots;
}

// LZF decompression (liblzf's format, as PCL's binary_compressed uses). False on a corrupt stream.
bool lzf_decompress(std::string_view in, std::string& out) {
  std::size_t ip = 0;
  std::size_t op = 0;
  while (ip < in.size()) {
    std::size_t ctrl = static_cast<unsigned char>(in[ip++]);
    if (ctrl < 32) {  // literal run of ctrl + 1 bytes
      ++ctrl;
      if (ip + ctrl > in.size() || op + ctrl > out.size()) return false;
      std::memcpy(&out[op], &in[ip], ctrl);
      ip += ctrl;
      op += ctrl;
      continue;
    }
    std::size_t length = ctrl >> 5;  // back reference
    std::size_t distance = (ctrl & 0x1f) << 8;
    if (length == 7) {
      if (ip >= in.size()) return false;
      length += static_cast<unsigned char>(in[ip++]);
    }
    if (ip >= in.size()) return false;
    distance += static_cast<unsigned char>(in[ip++]);
    length += 2;
    if (distance + 1 > op || op + length > out.size()) return false;
    for (std::size_t k = 0; k < length; ++k, ++op) out[op] = out[op - distance - 1];  // may overlap
  }
  return op == out.size();
}

// The binary body of a binary_compressed PCD, rearranged to one point after another.
std::string pcd_decompress(const std::string& file, const PcdHeader& header, std::string_view body) {
  if (body.size() < 8) throw InputError(file, "truncated body: no compressed sizes");
  const auto compressed = static_cast<std::size_t>(load_scalar(body.data(), Scalar::kU32, kHostBigEndian));
  const auto uncompressed = static_cast<std::size_t>(load_scalar(body.data() + 4, Scalar::kU32, kHostBigEndian));
  if (uncompressed != header.points * header.point_size) {
    throw InputError(file, "bad body: uncompressed size " + std::to_string(uncompressed) + " is not POINTS * point size " +
                               std::to_string(header.points * header.point_size));
  }
  if (body.size() - 8 < compressed) throw InputError(file, "truncated body: compressed data is cut short");
  // LZF expands 3 bytes into at most 264: a larger claim is a bad header, refused before allocating it (a
  // 120-byte file claimed 4 GiB).
  if (uncompressed / 88 > compressed + 3) {
    throw InputError(file, "bad body: " + std::to_string(compressed) + " compressed bytes cannot hold the " +
                               std::to_string(uncompressed) + " bytes of POINTS * point size");
  }
  std::string by_field(uncompressed, '\0');
  if (!lzf_decompress(body.substr(8, compressed), by_field)) throw InputError(file, "bad body: corrupt LZF data");
  std::string by_point(uncompressed, '\0');
  std::size_t source = 0;
  for (const PcdField& field : header.fields) {
    const std::size_t size = scalar_size(field.type) * field.count;
    for (std::size_t p = 0; p < header.points; ++p, source += size) {
      std::memcpy(&by_point[p * header.point_size + field.offset], &by_field[source], size);
    }
  }
  return by_point;
}

// An ASCII rgb token: PCL writes the packed value as an unsigned integer; older files print the float
// whose bits hold it.
std::optional<std::uint32_t> parse_packed_rgb(std::string_view token, Scalar type) {
  if (const std::optional<std::uint32_t> packed = parse_number<std::uint32_t>(token)) return packed;
  if (type != Scalar::kF32) return std::nullopt;
  const std::optional<float> value = parse_number<float>(token);
  if (!value) return std::nullopt;
  std::uint32_t packed = 0;
  std::memcpy(&packed, &*value, sizeof(packed));
  return packed;
}

PointCloud read_pcd_ascii(const std::string& file, const PcdHeader& header, const PointSlots& slots,
                          std::string_view body_text) {
  PointCloud cloud;
  cloud.reserve(std::min(header.points, body_text.size() / 2), slots.has_rgb());  // >= 2 bytes a point
  BodyReader body(body_text, true, false);
  std::vector<double> values(header.fields.size());
  std::uint32_t packed = 0;
  for (std::size_t p = 0; p < header.points; ++p) {
    for (std::size_t f = 0; f < header.fields.size(); ++f) {
      const PcdField& field = header.fields[f];
      for (std::size_t c = 0; c < field.count; ++c) {
        const std::optional<std::string_view> token = body.next_token();
        if (!token) {
          throw InputError(file, "truncated body: " + std::to_string(p) + " of " + std::to_string(header.points) +
                                     " points read");
        }
        if (c > 0) continue;
        std::optional<double> value;
        if (static_cast<int>(f) == slots.rgb[0]) {
          const std::optional<std::uint32_t> rgb = parse_packed_rgb(*token, field.type);
          if (rgb) packed = *rgb;
          value = rgb ? std::optional<double>(0.0) : std::nullopt;
        } else {
          value = parse_value(*token, field.type);
        }
        if (!value) {
          throw InputError(file, "bad number '" + std::string(*token) + "' in point " + std::to_string(p + 1) +
                                     ", field '" + field.name + "'");
        }
        values[f] = *value;
      }
    }
    const Eigen::Vector3f point(static_cast<float>(values[slots.xyz[0]]), static_cast<float>(values[slots.xyz[1]]),
                                static_cast<float>(values[slots.xyz[2]]));
    if (slots.has_rgb()) {
      cloud.push_back(point, unpack_rgb(packed));
    } else {
      cloud.push_back(point);
    }
  }
  return cloud;
}

PointCloud read_pcd_binary(const std::string& file, const PcdHeader& header, const PointSlots& slots,
                           std::string_view body) {
  if (body.size() < header.points * header.point_size) {
    const std::size_t complete = header.point_size == 0 ? 0 : body.size() / header.point_size;
    throw InputError(file, "truncated body: " + std::to_string(complete) + " of " + std::to_string(header.points) +
                               " points present");
  }
  PointCloud cloud;
  cloud.reserve(header.points, slots.has_rgb());
  const bool swap = kHostBigEndian;
  for (std::size_t p = 0; p < header.points; ++p) {
    const char* point = body.data() + p * header.point_size;
    Eigen::Vector3f xyz;
    for (int axis = 0; axis < 3; ++axis) {
      const PcdField& field = header.fields[slots.xyz[axis]];
      xyz[axis] = static_cast<float>(load_scalar(point + field.offset, field.type, swap));
    }
    if (!slots.has_rgb()) {
      cloud.push_back(xyz);
      continue;
    }
    std::uint32_t packed = 0;
    std::memcpy(&packed, point + header.fields[slots.rgb[0]].offset, sizeof(packed));
    if (swap) packed = load_raw<std::uint32_t>(reinterpret_cast<const char*>(&packed), true);
    cloud.push_back(xyz, unpack_rgb(packed));
  }
  return cloud;
}

std::string pcd_header_text(const PointCloud& cloud, CloudEncoding encoding) {
  const bool rgb = cloud.has_colors();
  std::string header = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n";
  header += rgb ? "FIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\n"
                : "FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\n";
  header += "WIDTH " + std::to_string(cloud.size()) + "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\n";
  header += "POINTS " + std::to_string(cloud.size()) + "\n";
  header += encoding == CloudEncoding::kAscii ? "DATA ascii\n" : "DATA binary\n";
  return header;
}

std::string lower_extension(const std::string& path) {
  std::string extension = fs::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

}  // namespace

void write_ply(const std::string& path, const PointCloud& cloud, CloudEncoding encoding) {
  const bool rgb = cloud.has_colors();
  const bool normal = cloud.has_normals();
  std::string data = ply_header_text(cloud, encoding);
  data.reserve(data.size() + cloud.size() * (encoding == CloudEncoding::kAscii ? 48 : 15) * (normal ? 2 : 1));
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    if (encoding == CloudEncoding::kBinary) {
      for (int axis = 0; axis < 3; ++axis) append_raw(data, p[axis]);
      if (rgb) data.append(reinterpret_cast<const char*>(cloud.colors[i].data()), 3);
      for (int axis = 0; normal && axis < 3; ++axis) append_raw(data, cloud.normals[i][axis]);
      continue;
    }
    for (int axis = 0; axis < 3; ++axis) {
      if (axis > 0) data += ' ';
      append_number(data, p[axis]);
    }
    for (int c = 0; rgb && c < 3; ++c) {
      data += ' ';
      append_number(data, std::uint32_t{cloud.colors[i][c]});
    }
    for (int axis = 0; normal && axis < 3; ++axis) {
      data += ' ';
      append_number(data, cloud.normals[i][axis]);
    }
    data += '\n';
  }
  write_whole_file(path, data);
}

PointCloud read_ply(const std::string& path) {
  const std::string data = read_whole_file(path);
  const PlyHeader header = parse_ply_header(path, data);
  const bool ascii = header.format == PlyFormat::kAscii;
  const bool swap = !ascii && ((header.format == PlyFormat::kBinaryBig) != kHostBigEndian);
  BodyReader body(std::string_view(data).substr(header.body_offset), ascii, swap);
  for (const PlyElement& element : header.elements) {
    std::vector<double> values(element.properties.size(), 0.0);
    if (element.name != "vertex") {  // skipped row by row (lists make rows variable in size)
      for (std::size_t row = 0; row < element.count && !element.properties.empty(); ++row) {
        if (!read_ply_row(body, element, values)) throw InputError(path, element_message(element, row, body));
      }
      continue;
    }
    const PointSlots slots = ply_slots(element);
    if (!slots.has_xyz()) throw InputError(path, "bad header: the vertex element has no x, y and z properties");
    PointCloud cloud;
    cloud.reserve(std::min(element.count, data.size() - header.body_offset), slots.has_rgb());  // >= 1 byte a row
    for (std::size_t row = 0; row < element.count; ++row) {
      if (!read_ply_row(body, element, values)) throw InputError(path, element_message(element, row, body));
      const Eigen::Vector3f point(static_cast<float>(values[slots.xyz[0]]), static_cast<float>(values[slots.xyz[1]]),
                                  static_cast<float>(values[slots.xyz[2]]));
      if (slots.has_normal()) {
        cloud.normals.emplace_back(static_cast<float>(values[slots.normal[0]]), static_cast<float>(values[slots.normal[1]]),
                                   static_cast<float>(values[slots.normal[2]]));
      }
      if (!slots.has_rgb()) {
        cloud.push_back(point);
        continue;
      }
      PointCloud::Rgb rgb;
      for (int c = 0; c < 3; ++c) rgb[c] = to_channel(values[slots.rgb[c]], element.properties[slots.rgb[c]].type);
      cloud.push_back(point, rgb);
    }
    return cloud;
  }
  throw InputError(path, "bad header: no 'vertex' element");
}

void write_pcd(const std::string& path, const PointCloud& cloud, CloudEncoding encoding) {
  const bool rgb = cloud.has_colors();
  std::string data = pcd_header_text(cloud, encoding);
  data.reserve(data.size() + cloud.size() * (encoding == CloudEncoding::kAscii ? 48 : 16));
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3f& p = cloud.points[i];
    if (encoding == CloudEncoding::kBinary) {
      for (int axis = 0; axis < 3; ++axis) append_raw(data, p[axis]);
      if (rgb) append_raw(data, pack_rgb(cloud.colors[i]));
      continue;
    }
    for (int axis = 0; axis < 3; ++axis) {
      if (axis > 0) data += ' ';
      append_number(data, p[axis]);
    }
    if (rgb) {
      data += ' ';
      append_number(data, pack_rgb(cloud.colors[i]));
    }
    data += '\n';
  }
  write_whole_file(path, data);
}

PointCloud read_pcd(const std::string& path) {
  const std::string data = read_whole_file(path);
  const PcdHeader header = parse_pcd_header(path, data);
  const PointSlots slots = pcd_slots(header);
  if (!slots.has_xyz()) throw InputError(path, "bad header: no x, y and z fields");
  const std::string_view body = std::string_view(data).substr(header.body_offset);
  switch (header.data) {
    case PcdData::kAscii: return read_pcd_ascii(path, header, slots, body);
    case PcdData::kBinary: return read_pcd_binary(path, header, slots, body);
    case PcdData::kBinaryCompressed: {
      const std::string by_point = pcd_decompress(path, header, body);
      return read_pcd_binary(path, header, slots, by_point);
    }
  }
  throw InputError(path, "bad header: unknown DATA");
}

void write_point_cloud(const std::string& path, const PointCloud& cloud) {
  const std::string extension = lower_extension(path);
  if (extension == ".ply") return write_ply(path, cloud);
  if (extension == ".pcd") return write_pcd(path, cloud);
  throw InputError(path, "unknown point cloud format '" + extension + "' (expected .ply or .pcd)");
}

PointCloud read_point_cloud(const std::string& path) {
  const std::string extension = lower_extension(path);
  if (extension == ".ply") return read_ply(path);
  if (extension == ".pcd") return read_pcd(path);
  throw InputError(path, "unknown point cloud format '" + extension + "' (expected .ply or .pcd)");
}

}  // namespace fleetslam::core
