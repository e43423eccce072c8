#pragma once
// Typed YAML configuration. A config struct keeps its defaults in its members and lists its fields
// once, in a visit function that both reads and writes it:
//
//   struct MatcherConfig {
//     double radius_px = 15.0;
//     int max_hamming = 50;
//     bool cross_validation = true;
//     template <class V> void visit(V& v) {
//       v("radius_px", radius_px, Limits<double>{0.5, 200.0});
//       v("max_hamming", max_hamming, Limits<int>{0, 256});
//       v("cross_validation", cross_validation);
//     }
//   };
//   auto cfg = load_config<MatcherConfig>("agent.yaml", "matching");
//
// Reading: absent keys keep their defaults; v.required(...) makes a key mandatory; unknown keys, wrong
// types and values outside the limits are InputErrors "file:section.key: why (line N)".
// Nested structs with a visit function read from a sub-map, std::vector<Struct> from a list of maps;
// enums read from names via v.choice(...).

#include <cstdint>
#include <filesystem>
#include <initializer_list>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace fleetslam::core {

template <class T>
struct Limits {
  T min = std::numeric_limits<T>::lowest();
  T max = std::numeric_limits<T>::max();
};

namespace detail {
template <class T, class = void>
struct HasVisit : std::false_type {};
}  // namespace detail

// Reads one YAML map into a config struct; see the file comment.
class ConfigReader {
 public:
  // Parses a whole file (throws InputError naming the file on unreadable or malformed YAML).
  static ConfigReader from_file(const std::filesystem::path& file);
  // Parses text; `name` stands for the file in messages.
  static ConfigReader from_string(const std::string& text, const std::string& name);

  ~ConfigReader();
  ConfigReader(ConfigReader&&) noexcept;
  ConfigReader& operator=(ConfigReader&&) noexcept;

  // The sub-map at a dotted key path ("agent.matching"); an absent section is an empty map
  // (every field keeps its default). A present non-map is an error.
  ConfigReader section(const std::string& dotted_key) const;
  bool has(const std::string& key) const;

  void operator()(const char* key, bool& value);
  void operator()(const char* key, int& value, Limits<int> limits = {});
  void operator()(const char* key, std::int64_t& value, Limits<std::int64_t> limits = {});
  void operator()(const char* key, double& value, Limits<double> limits = {});
  void operator()(const char* key, std::string& value);
  void operator()(const char* key, std::vector<double>& value);
  void operator()(const char* key, std::vector<std::string>& value);

  template <class Struct, std::enable_if_t<detail::HasVisit<Struct>::value, int> = 0>
  void operator()(const char* key, Struct& value) {
    mark_seen(key);
    ConfigReader child = section(key);
    value.visit(child);
    child.finish();
  }

  // A list of maps, each read into a Struct that starts from `prototype` (defaults for every item).
  template <class Struct, std::enable_if_t<detail::HasVisit<Struct>::value, int> = 0>
  void operator()(const char* key, std::vector<Struct>& value, const Struct& prototype = Struct{}) {
    mark_seen(key);
    const std::size_t count = list_size(key);
    if (count == kAbsent) return;
    std::vector<Struct> items;
    for (std::size_t i = 0; i < count; ++i) {
      Struct item = prototype;
      ConfigReader child = list_item(key, i);
      item.visit(child);
      child.finish();
      items.push_back(std::move(item));
    }
    value = std::move(items);
  }

  // Like operator() but the key must be present.
  template <class T, class... Extra>
  void required(const char* key, T& value, Extra&&... extra) {
    require_present(key);
    (*this)(key, value, std::forward<Extra>(extra)...);
  }

  // Enum (or any value) chosen by name: v.choice("policy", policy, {{"orbslam3", Policy::kOrbslam3}, ...}).
  template <class E>
  void choice(const char* key, E& value, std::initializer_list<std::pair<const char*, E>> options) {
    std::vector<std::string> names;
    for (const auto& option : options) names.emplace_back(option.first);
    std::optional<std::size_t> picked = read_choice(key, names);
    if (picked) value = (options.begin() + *picked)->second;
  }

  // Throws InputError for keys present in the map that no visit asked for.
  void finish() const;
  // Accepts `key` as known without reading it: a section that another layer reads from the same file.
  void skip(const char* key) { mark_seen(key); }

  // "file" and the dotted path of this map, for messages.
  std::string where(const std::string& key) const;

 private:
  struct Impl;
  explicit ConfigReader(std::unique_ptr<Impl> impl);
  void mark_seen(const char* key);
  void require_present(const char* key) const;
  std::optional<std::size_t> read_choice(const char* key, const std::vector<std::string>& names);
  static constexpr std::size_t kAbsent = static_cast<std::size_t>(-1);
  // Number of items of the list at key (kAbsent when the key is absent); throws when not a list.
  std::size_t list_size(const char* key) const;
  // Reader over the i-th item (a map) of the list at key; its messages say "key[i].field".
  ConfigReader list_item(const char* key, std::size_t index) const;

  std::unique_ptr<Impl> impl_;
};

// Writes a config struct as YAML (the effective config written beside every run's outputs).
class ConfigWriter {
 public:
  ConfigWriter();
  ~ConfigWriter();
  ConfigWriter(const ConfigWriter&) = delete;
  ConfigWriter& operator=(const ConfigWriter&) = delete;

  void operator()(const char* key, const bool& value);
  void operator()(const char* key, const int& value, Limits<int> = {});
  void operator()(const char* key, const std::int64_t& value, Limits<std::int64_t> = {});
  void operator()(const char* key, const double& value, Limits<double> = {});
  void operator()(const char* key, const std::string& value);
  void operator()(const char* key, const std::vector<double>& value);
  void operator()(const char* key, const std::vector<std::string>& value);

  template <class Struct, std::enable_if_t<detail::HasVisit<Struct>::value, int> = 0>
  void operator()(const char* key, Struct& value) {
    begin_map(key);
    value.visit(*this);
    end_map();
  }
  template <class Struct, std::enable_if_t<detail::HasVisit<Struct>::value, int> = 0>
  void operator()(const char* key, std::vector<Struct>& value, const Struct& = Struct{}) {
    begin_list(key);
    for (Struct& item : value) {
      begin_list_item();
      item.visit(*this);
      end_map();
    }
    end_list();
  }
  template <class T, class... Extra>
  void required(const char* key, T& value, Extra&&... extra) {
    (*this)(key, value, std::forward<Extra>(extra)...);
  }
  template <class E>
  void choice(const char* key, const E& value, std::initializer_list<std::pair<const char*, E>> options) {
    for (const auto& option : options) {
      if (option.second == value) {
        (*this)(key, std::string(option.first));
        return;
      }
    }
  }

  void begin_map(const char* key);
  void end_map();
  void begin_list(const char* key);
  void begin_list_item();
  void end_list();
  std::string str() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

namespace detail {
template <class T>
struct HasVisit<T, std::void_t<decltype(std::declval<T&>().visit(std::declval<ConfigReader&>()))>>
    : std::true_type {};
}  // namespace detail

// Checks a config struct built in code as reading it from YAML would: every number finite and within the
// limits its visit gives (check_config below). Messages name the value as "name.key" ("name.list[i].key").
class ConfigChecker {
 public:
  explicit ConfigChecker(std::string path) : path_(std::move(path)) {}

  void operator()(const char*, const bool&) {}
  void operator()(const char* key, const int& value, Limits<int> limits = {});
  void operator()(const char* key, const std::int64_t& value, Limits<std::int64_t> limits = {});
  void operator()(const char* key, const double& value, Limits<double> limits = {});
  void operator()(const char*, const std::string&) {}
  void operator()(const char* key, const std::vector<double>& value);
  void operator()(const char*, const std::vector<std::string>&) {}
  template <class Struct, std::enable_if_t<detail::HasVisit<Struct>::value, int> = 0>
  void operator()(const char* key, Struct& value) {
    ConfigChecker nested(where(key));
    value.visit(nested);
  }
  template <class Struct, std::enable_if_t<detail::HasVisit<Struct>::value, int> = 0>
  void operator()(const char* key, std::vector<Struct>& value, const Struct& = Struct{}) {
    for (std::size_t i = 0; i < value.size(); ++i) {
      ConfigChecker item(where(key) + "[" + std::to_string(i) + "]");
      value[i].visit(item);
    }
  }
  template <class T, class... Extra>
  void required(const char* key, T& value, Extra&&... extra) {
    (*this)(key, value, std::forward<Extra>(extra)...);
  }
  template <class E>
  void choice(const char*, const E&, std::initializer_list<std::pair<const char*, E>>) {}

 private:
  std::string where(const char* key) const { return path_.empty() ? std::string(key) : path_ + "." + key; }
  std::string path_;
};

// Throws InputError naming `name`.key when a field of a config built in code is non-finite or outside
// the limits its visit gives: components check their Config in their constructor, so that one set in code
// is held to what its YAML would be.
template <class Config>
void check_config(Config config, const std::string& name) {
  ConfigChecker checker(name);
  config.visit(checker);
}

// Reads `section` (dotted path, "" for the whole file) of a YAML file into Config, rejecting unknown keys.
template <class Config>
Config load_config(const ConfigReader& root, const std::string& section = "") {
  Config config;
  ConfigReader reader = section.empty() ? root.section("") : root.section(section);
  config.visit(reader);
  reader.finish();
  return config;
}
template <class Config>
Config load_config(const std::filesystem::path& file, const std::string& section = "") {
  return load_config<Config>(ConfigReader::from_file(file), section);
}

// YAML text of a config struct, every field with its effective value.
template <class Config>
std::string config_to_yaml(Config config) {
  ConfigWriter writer;
  config.visit(writer);
  return writer.str();
}

}  // namespace fleetslam::core
