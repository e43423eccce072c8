#include "fleetslam/core/config.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <vector>

#include <yaml-cpp/yaml.h>

#include "fleetslam/core/error.hpp"

namespace fleetslam::core {

struct ConfigReader::Impl {
  YAML::Node node;           // a map (possibly empty)
  std::string file;          // for messages
  std::string path;          // dotted path of this map from the file root, "" at the root
  std::set<std::string> seen;
};

namespace {

std::string join_key(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}

std::string line_suffix(const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  if (mark.line < 0) return "";
  return " (line " + std::to_string(mark.line + 1) + ")";
}

std::string describe(const YAML::Node& node) {
  switch (node.Type()) {
    case YAML::NodeType::Map: return "a map";
    case YAML::NodeType::Sequence: return "a list";
    case YAML::NodeType::Null: return "nothing";
    case YAML::NodeType::Scalar: return "'" + node.Scalar() + "'";
    default: return "an undefined value";
  }
}

// Shortest decimal text that reads back to the same double.
std::string format_double(double value) {
  char buffer[64];
  for (int precision = 15; precision <= 17; ++precision) {
    std::snprintf(buffer, sizeof buffer, "%.*g", precision, value);
    if (std::strtod(buffer, nullptr) == value) break;
  }
  std::string text = buffer;
  if (text.find_first_of(".eEn") == std::string::npos) text += ".0";  // keep it a float in YAML
  return text;
}

template <class T>
std::string format_limit(T value) {
  if constexpr (std::is_floating_point_v<T>) {
    return format_double(static_cast<double>(value));
  } else {
    return std::to_string(value);
  }
}

}  // namespace

namespace {

template <class T>
void check_number(const std::string& where, T value, Limits<T> limits) {
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(value)) throw InputError(where, "expected a finite number, got " + format_limit(value));
  }
  if (value < limits.min || value > limits.max) {
    throw InputError(where, format_limit(value) + " is outside [" + format_limit(limits.min) + ", " +
                                format_limit(limits.max) + "]");
  }
}

}  // namespace

void ConfigChecker::operator()(const char* key, const int& value, Limits<int> limits) {
  check_number(where(key), value, limits);
}

void ConfigChecker::operator()(const char* key, const std::int64_t& value, Limits<std::int64_t> limits) {
  check_number(where(key), value, limits);
}

void ConfigChecker::operator()(const char* key, const double& value, Limits<double> limits) {
  check_number(where(key), value, limits);
}

void ConfigChecker::operator()(const char* key, const std::vector<double>& value) {
  for (std::size_t i = 0; i < value.size(); ++i) {
    check_number(where(key) + "[" + std::to_string(i) + "]", value[i], Limits<double>{});
  }
}

ConfigReader::ConfigReader(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ConfigReader::~ConfigReader() = default;
ConfigReader::ConfigReader(ConfigReader&&) noexcept = default;
ConfigReader& ConfigReader::operator=(ConfigReader&&) noexcept = default;

namespace {

// A key given twice in one map: yaml-cpp keeps both and a lookup finds the first, so a later override was
// dropped without a word (and never checked against its limits). Also refuses an alias inside the node it
// names (`a: &x [*x]`): yaml-cpp builds a node that contains itself, which every walk would follow
// forever. `open` holds the nodes being checked (the path from the root), `done` those checked already:
// a node shared through aliases is checked once.
void refuse_duplicate_keys(const YAML::Node& node, const std::string& name, std::vector<YAML::Node>& open,
                           std::vector<YAML::Node>& done) {
  if (!node.IsMap() && !node.IsSequence()) return;
  const auto holds = [&](const std::vector<YAML::Node>& nodes) {
    return std::any_of(nodes.begin(), nodes.end(), [&](const YAML::Node& n) { return n.is(node); });
  };
  if (holds(open)) {
    throw InputError(name + ":" + std::to_string(node.Mark().line + 1),
                     "a YAML alias refers to a node that contains it: the node would contain itself");
  }
  if (holds(done)) return;
  open.push_back(node);
  if (node.IsMap()) {
    std::map<std::string, int> first_line;
    for (const auto& entry : node) {
      if (entry.first.IsScalar()) {
        const std::string& key = entry.first.Scalar();
        const int line = entry.first.Mark().line + 1;
        const auto [it, inserted] = first_line.emplace(key, line);
        if (!inserted) {
          throw InputError(name + ":" + std::to_string(line),
                           "key '" + key + "' given twice (first on line " + std::to_string(it->second) + ")");
        }
      }
      refuse_duplicate_keys(entry.first, name, open, done);
      refuse_duplicate_keys(entry.second, name, open, done);
    }
  } else {
    for (const auto& element : node) refuse_duplicate_keys(element, name, open, done);
  }
  open.pop_back();
  done.push_back(node);
}

}  // namespace

ConfigReader ConfigReader::from_string(const std::string& text, const std::string& name) {
  auto impl = std::make_unique<Impl>();
  impl->file = name;
  try {
    // One document: a second one (after "---") would be dropped unread.
    const std::vector<YAML::Node> documents = YAML::LoadAll(text);
    if (documents.size() > 1) {
      throw InputError(name + ":" + std::to_string(documents[1].Mark().line + 1),
                       "holds " + std::to_string(documents.size()) + " YAML documents; a config is one");
    }
    // Node::operator= writes through to the referenced node; reset() rebinds (used throughout).
    impl->node.reset(documents.empty() ? YAML::Node() : documents.front());
  } catch (const YAML::Exception& e) {
    throw InputError(name + ":" + std::to_string(e.mark.line + 1), "malformed YAML: " + e.msg);
  }
  std::vector<YAML::Node> open, done;
  refuse_duplicate_keys(impl->node, name, open, done);
  if (impl->node.IsNull()) {
    impl->node.reset(YAML::Node(YAML::NodeType::Map));
  } else if (!impl->node.IsMap()) {
    throw InputError(name, "expected a YAML map at the top level, got " + describe(impl->node));
  }
  return ConfigReader(std::move(impl));
}

ConfigReader ConfigReader::from_file(const std::filesystem::path& file) {
  std::error_code ec;
  // An ifstream opens a folder and reads nothing: it would be an empty config, all defaults.
  if (std::filesystem::is_directory(file, ec)) throw InputError(file.string(), "is a folder, not a config file");
  std::ifstream in(file);
  if (!in) throw InputError(file.string(), "cannot open config file");
  std::stringstream text;
  text << in.rdbuf();
  return from_string(text.str(), file.string());
}

std::string ConfigReader::where(const std::string& key) const {
  return impl_->file + ":" + join_key(impl_->path, key);
}

bool ConfigReader::has(const std::string& key) const {
  const YAML::Node& node = impl_->node;
  return static_cast<bool>(node[key]);
}

ConfigReader ConfigReader::section(const std::string& dotted_key) const {
  auto impl = std::make_unique<Impl>();
  impl->file = impl_->file;
  impl->path = impl_->path;
  impl->node.reset(impl_->node);
  std::stringstream parts(dotted_key);
  std::string part;
  while (std::getline(parts, part, '.')) {
    if (part.empty()) continue;
    const YAML::Node& parent = impl->node;
    YAML::Node child = parent[part];
    impl->path = join_key(impl->path, part);
    if (!child || child.IsNull()) {
      impl->node.reset(YAML::Node(YAML::NodeType::Map));
    } else if (!child.IsMap()) {
      throw InputError(impl->file + ":" + impl->path,
                       "expected a map, got " + describe(child) + line_suffix(child));
    } else {
      impl->node.reset(child);
    }
  }
  return ConfigReader(std::move(impl));
}

void ConfigReader::mark_seen(const char* key) { impl_->seen.insert(key); }

void ConfigReader::require_present(const char* key) const {
  const YAML::Node& node = impl_->node;
  if (!node[key]) throw InputError(where(key), "required key is missing");
}

namespace {

// The scalar at key, or an undefined node when absent. Throws when present but not a scalar.
// The line of `key` in `map`: an empty value (a null node) carries no position of its own that names it.
std::string key_line_suffix(const YAML::Node& map, const char* key) {
  for (const auto& entry : map) {
    if (entry.first.IsScalar() && entry.first.Scalar() == key) return line_suffix(entry.first);
  }
  return "";
}

YAML::Node scalar_at(const YAML::Node& map, const std::string& where, const char* key, const char* expected) {
  YAML::Node value = map[key];
  if (!value) return value;
  if (!value.IsScalar()) {
    throw InputError(where, std::string("expected ") + expected + ", got " + describe(value) +
                                (value.IsNull() ? key_line_suffix(map, key) : line_suffix(value)));
  }
  return value;
}

template <class T>
void read_number(const YAML::Node& map, const std::string& where, const char* key, T& out, Limits<T> limits,
                 const char* expected) {
  const YAML::Node value = scalar_at(map, where, key, expected);
  if (!value) return;
  T parsed{};
  if constexpr (std::is_integral_v<T>) {
    // yaml-cpp reads "010" as octal 8 (and refuses "09") while a real-valued key reads 10: refused.
    const std::string& text = value.Scalar();
    const std::size_t digits = !text.empty() && (text[0] == '+' || text[0] == '-') ? 1 : 0;
    if (text.size() > digits + 1 && text[digits] == '0' && std::isdigit(static_cast<unsigned char>(text[digits + 1])) != 0) {
      throw InputError(where, "'" + text + "' has a leading zero (octal in YAML); write it without" + line_suffix(value));
    }
  }
  try {
    parsed = value.as<T>();
  } catch (const YAML::Exception&) {
    throw InputError(where, std::string("expected ") + expected + ", got " + describe(value) + line_suffix(value));
  }
  if constexpr (std::is_floating_point_v<T>) {
    if (!std::isfinite(parsed)) {
      throw InputError(where, "expected a finite number, got " + describe(value) + line_suffix(value));
    }
  }
  if (parsed < limits.min || parsed > limits.max) {
    throw InputError(where, value.Scalar() + " is outside [" + format_limit(limits.min) + ", " +
                                format_limit(limits.max) + "]" + line_suffix(value));
  }
  out = parsed;
}

}  // namespace

void ConfigReader::operator()(const char* key, bool& value) {
  mark_seen(key);
  const YAML::Node node = scalar_at(impl_->node, where(key), key, "true or false");
  if (!node) return;
  try {
    value = node.as<bool>();
  } catch (const YAML::Exception&) {
    throw InputError(where(key), "expected true or false, got " + describe(node) + line_suffix(node));
  }
}

void ConfigReader::operator()(const char* key, int& value, Limits<int> limits) {
  mark_seen(key);
  read_number(impl_->node, where(key), key, value, limits, "an integer");
}

void ConfigReader::operator()(const char* key, std::int64_t& value, Limits<std::int64_t> limits) {
  mark_seen(key);
  read_number(impl_->node, where(key), key, value, limits, "an integer");
}

void ConfigReader::operator()(const char* key, double& value, Limits<double> limits) {
  mark_seen(key);
  read_number(impl_->node, where(key), key, value, limits, "a number");
}

void ConfigReader::operator()(const char* key, std::string& value) {
  mark_seen(key);
  const YAML::Node node = scalar_at(impl_->node, where(key), key, "a string");
  if (node) value = node.Scalar();
}

void ConfigReader::operator()(const char* key, std::vector<double>& value) {
  mark_seen(key);
  const YAML::Node& map = impl_->node;
  const YAML::Node node = map[key];
  if (!node) return;
  if (!node.IsSequence()) {
    throw InputError(where(key), "expected a list of numbers, got " + describe(node) + line_suffix(node));
  }
  std::vector<double> parsed;
  for (std::size_t i = 0; i < node.size(); ++i) {
    const std::string item_where = where(key) + "[" + std::to_string(i) + "]";
    double item = 0.0;
    try {
      if (!node[i].IsScalar()) throw YAML::Exception(node[i].Mark(), "not a scalar");
      item = node[i].as<double>();
    } catch (const YAML::Exception&) {
      throw InputError(item_where, "expected a number, got " + describe(node[i]) + line_suffix(node[i]));
    }
    if (!std::isfinite(item)) throw InputError(item_where, "expected a finite number" + line_suffix(node[i]));
    parsed.push_back(item);
  }
  value = std::move(parsed);
}

void ConfigReader::operator()(const char* key, std::vector<std::string>& value) {
  mark_seen(key);
  const YAML::Node& map = impl_->node;
  const YAML::Node node = map[key];
  if (!node) return;
  if (!node.IsSequence()) {
    throw InputError(where(key), "expected a list of strings, got " + describe(node) + line_suffix(node));
  }
  std::vector<std::string> parsed;
  for (std::size_t i = 0; i < node.size(); ++i) {
    if (!node[i].IsScalar()) {
      throw InputError(where(key) + "[" + std::to_string(i) + "]",
                       "expected a string, got " + describe(node[i]) + line_suffix(node[i]));
    }
    parsed.push_back(node[i].Scalar());
  }
  value = std::move(parsed);
}

std::size_t ConfigReader::list_size(const char* key) const {
  const YAML::Node& map = impl_->node;
  const YAML::Node node = map[key];
  if (!node || node.IsNull()) return kAbsent;
  if (!node.IsSequence()) {
    throw InputError(where(key), "expected a list of maps, got " + describe(node) + line_suffix(node));
  }
  return node.size();
}

ConfigReader ConfigReader::list_item(const char* key, std::size_t index) const {
  const YAML::Node& map = impl_->node;
  const YAML::Node item = map[key][index];
  auto impl = std::make_unique<Impl>();
  impl->file = impl_->file;
  impl->path = join_key(impl_->path, key) + "[" + std::to_string(index) + "]";
  if (!item.IsMap()) {
    throw InputError(impl->file + ":" + impl->path, "expected a map, got " + describe(item) + line_suffix(item));
  }
  impl->node.reset(item);
  return ConfigReader(std::move(impl));
}

std::optional<std::size_t> ConfigReader::read_choice(const char* key, const std::vector<std::string>& names) {
  std::string name;
  (*this)(key, name);
  if (name.empty() && !has(key)) return std::nullopt;
  for (std::size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return i;
  }
  std::string known;
  for (const auto& n : names) known += (known.empty() ? "" : ", ") + n;
  const YAML::Node& map = impl_->node;
  throw InputError(where(key), "unknown value '" + name + "' (expected one of: " + known + ")" +
                                   line_suffix(map[key]));
}

void ConfigReader::finish() const {
  for (const auto& entry : impl_->node) {
    const std::string key = entry.first.Scalar();
    if (impl_->seen.count(key) == 0) {
      std::string known;
      for (const auto& k : impl_->seen) known += (known.empty() ? "" : ", ") + k;
      throw InputError(where(key), "unknown key" + line_suffix(entry.first) +
                                       (known.empty() ? "" : " (known keys: " + known + ")"));
    }
  }
}

// ---------------------------------------------------------------------------------------------------------

struct ConfigWriter::Impl {
  YAML::Node root{YAML::NodeType::Map};
  std::vector<YAML::Node> stack{root};
  YAML::Node& top() { return stack.back(); }
};

ConfigWriter::ConfigWriter() : impl_(std::make_unique<Impl>()) {}
ConfigWriter::~ConfigWriter() = default;

void ConfigWriter::operator()(const char* key, const bool& value) { impl_->top()[key] = value; }
void ConfigWriter::operator()(const char* key, const int& value, Limits<int>) { impl_->top()[key] = value; }
void ConfigWriter::operator()(const char* key, const std::int64_t& value, Limits<std::int64_t>) {
  impl_->top()[key] = value;
}
void ConfigWriter::operator()(const char* key, const double& value, Limits<double>) {
  impl_->top()[key] = format_double(value);
}
void ConfigWriter::operator()(const char* key, const std::string& value) { impl_->top()[key] = value; }
void ConfigWriter::operator()(const char* key, const std::vector<double>& value) {
  YAML::Node list(YAML::NodeType::Sequence);
  for (double v : value) list.push_back(format_double(v));
  list.SetStyle(YAML::EmitterStyle::Flow);
  impl_->top()[key] = list;
}
void ConfigWriter::operator()(const char* key, const std::vector<std::string>& value) {
  YAML::Node list(YAML::NodeType::Sequence);
  for (const auto& v : value) list.push_back(v);
  list.SetStyle(YAML::EmitterStyle::Flow);
  impl_->top()[key] = list;
}

void ConfigWriter::begin_map(const char* key) {
  YAML::Node child(YAML::NodeType::Map);
  impl_->top()[key] = child;
  impl_->stack.push_back(child);
}

void ConfigWriter::begin_list(const char* key) {
  YAML::Node list(YAML::NodeType::Sequence);
  impl_->top()[key] = list;
  impl_->stack.push_back(list);
}

void ConfigWriter::begin_list_item() {
  YAML::Node item(YAML::NodeType::Map);
  impl_->top().push_back(item);
  impl_->stack.push_back(item);
}

void ConfigWriter::end_list() { end_map(); }

void ConfigWriter::end_map() {
  FLEETSLAM_CHECK(impl_->stack.size() > 1, "end_map without begin_map");
  impl_->stack.pop_back();
}

std::string ConfigWriter::str() const {
  YAML::Emitter out;
  out << impl_->root;
  return std::string(out.c_str()) + "\n";
}

}  // namespace fleetslam::core
