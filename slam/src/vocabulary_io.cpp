// Vocabulary files: this project's binary format and the DBoW2 text format (parsers written here).
//
// Binary format, version 1, little-endian throughout:
//   offset 0   8 bytes  magic "FSVOCAB\0"
//          8   u32      version (1)
//         12   u32      descriptor bytes (32)
//         16   u32      k (branching)
//         20   u32      L (depth levels)
//         24   u64      nodes n
//         32   u64      words w
//         40   u64      training images (0: unknown)
//         48   u64      training descriptors (0: unknown)
//         56   n x u32  parent per node (root 0xffffffff), breadth-first order
//              n x 32   descriptor per node
//              n x u32  word per node (0xffffffff for inner nodes)
//              w x f64  IDF per word (IEEE 754 bits)
//              u64      FNV-1a 64 of every byte before it
// A reader checks the magic, version, descriptor size, that the file is exactly as long as the sizes
// say, the checksum, then the tree (check_vocabulary_tree); arrays are copied out of one read of the file.

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "binary_io.hpp"
#include "fleetslam/core/error.hpp"
#include "fleetslam/slam/vocabulary.hpp"

namespace fleetslam::slam {
namespace {

namespace fs = std::filesystem;

constexpr char kMagic[8] = {'F', 'S', 'V', 'O', 'C', 'A', 'B', '\0'};
constexpr std::uint32_t kVersion = 1;
constexpr std::size_t kHeaderBytes = 56;
constexpr std::size_t kBytes = kDescriptorBytes;

std::string read_file(const fs::path& file) {
  std::error_code ec;
  if (fs::is_directory(file, ec)) throw InputError(file.string(), "a folder, not a vocabulary file");
  std::ifstream in(file, std::ios::binary | std::ios::ate);
  if (!in) throw InputError(file.string(), "cannot open the vocabulary file");
  const std::streamoff size = in.tellg();
  if (size < 0) throw InputError(file.string(), "cannot read the vocabulary file");
  std::string data(static_cast<std::size_t>(size), '\0');
  in.seekg(0);
  in.read(data.data(), static_cast<std::streamsize>(size));
  if (!in) throw InputError(file.string(), "cannot read the vocabulary file");
  return data;
}

void write_file(const fs::path& file, const std::string& data) {
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  if (!out) throw InputError(file.string(), "cannot open for writing");
  out.write(data.data(), static_cast<std::streamsize>(data.size()));
  out.close();
  if (!out) throw InputError(file.string(), "cannot write the vocabulary");
}

using binary::fnv1a;
using binary::Reader;
using binary::Writer;

bool has_magic(const std::string& data) {
  return data.size() >= sizeof kMagic && std::memcmp(data.data(), kMagic, sizeof kMagic) == 0;
}

Vocabulary checked(VocabularyTree tree, const std::string& where) {
  const std::string why = check_vocabulary_tree(tree);
  if (!why.empty()) throw InputError(where, "inconsistent vocabulary tree: " + why);
  return Vocabulary(std::move(tree));
}

Vocabulary parse_binary(const std::string& data, const std::string& where) {
  if (data.size() < kHeaderBytes + 8) {
    throw InputError(where, "truncated: " + std::to_string(data.size()) + " bytes, less than a vocabulary header");
  }
  if (!has_magic(data)) throw InputError(where, "not a fleetslam binary vocabulary (bad magic)");
  Reader in(data, 0, data.size(), where);
  char magic[sizeof kMagic];
  in.bytes(magic, sizeof magic);
  const std::uint32_t version = in.u32();
  if (version != kVersion) {
    throw InputError(where, "vocabulary format version " + std::to_string(version) + " is not supported (this build reads " +
                                std::to_string(kVersion) + ")");
  }
  const std::uint32_t descriptor_bytes = in.u32();
  if (descriptor_bytes != kBytes) {
    throw InputError(where, "descriptors of " + std::to_string(descriptor_bytes) + " bytes, expected " + std::to_string(kBytes));
  }
  VocabularyTree tree;
  tree.branching = static_cast<int>(std::min<std::uint32_t>(in.u32(), 1u << 30));
  tree.depth_levels = static_cast<int>(std::min<std::uint32_t>(in.u32(), 1u << 30));
  const std::uint64_t nodes = in.u64();
  const std::uint64_t words = in.u64();
  tree.training_images = in.u64();
  tree.training_descriptors = in.u64();
  if (nodes >= kNoNode || words > nodes) {
    throw InputError(where, "header sizes out of range (" + std::to_string(nodes) + " nodes, " + std::to_string(words) + " words)");
  }
  const std::uint64_t expected = kHeaderBytes + nodes * (4 + kBytes + 4) + words * 8 + 8;
  if (data.size() != expected) {
    throw InputError(where, std::string(data.size() < expected ? "truncated" : "trailing bytes") + ": " +
                                std::to_string(data.size()) + " bytes, the header's sizes need " + std::to_string(expected));
  }
  std::uint64_t stored_sum = 0;
  for (int i = 0; i < 8; ++i) stored_sum |= std::uint64_t{static_cast<unsigned char>(data[data.size() - 8 + static_cast<std::size_t>(i)])} << (8 * i);
  if (fnv1a(data.data(), data.size() - 8) != stored_sum) throw InputError(where, "checksum mismatch: the file is corrupted");
  const auto n = static_cast<std::size_t>(nodes);
  tree.parent.resize(n);
  for (NodeId& p : tree.parent) p = in.u32();
  tree.descriptors.resize(n * kBytes);
  in.bytes(tree.descriptors.data(), tree.descriptors.size());
  tree.word.resize(n);
  for (WordId& w : tree.word) w = in.u32();
  tree.word_weight.resize(static_cast<std::size_t>(words));
  for (double& w : tree.word_weight) w = in.f64();
  return checked(std::move(tree), where);
}

// ---- DBoW2 text ----

std::vector<std::string_view> split_tokens(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

long long parse_int(std::string_view token, const std::string& where, const char* what) {
  long long value = 0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc() || end != token.data() + token.size()) {
    throw InputError(where, std::string(what) + " '" + std::string(token) + "' is not an integer");
  }
  return value;
}

double parse_double(std::string_view token, const std::string& where, const char* what) {
  double value = 0.0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  if (ec != std::errc() || end != token.data() + token.size() || !std::isfinite(value)) {
    throw InputError(where, std::string(what) + " '" + std::string(token) + "' is not a finite number");
  }
  return value;
}

// One node line of the file (file node ids from 1; the root is 0).
struct TextNode {
  std::size_t parent = 0;
  bool leaf = false;
  std::size_t line = 0;
  std::size_t depth = 0;
  std::vector<std::size_t> children;
  std::uint8_t descriptor[kBytes] = {};
  double weight = 0.0;
};

struct TextHeader {
  int k = 0;
  int levels = 0;
};

TextHeader parse_header(std::string_view line, const std::string& file) {
  const std::string where = at_line(file, 1);
  const auto tokens = split_tokens(line);
  if (tokens.size() != 4) {
    throw InputError(where, "expected a DBoW2 header 'k L scoring weighting', got " + std::to_string(tokens.size()) + " fields");
  }
  TextHeader h;
  const long long k = parse_int(tokens[0], where, "k");
  const long long levels = parse_int(tokens[1], where, "L");
  const long long scoring = parse_int(tokens[2], where, "scoring");
  const long long weighting = parse_int(tokens[3], where, "weighting");
  if (k < 1 || k > 65535) throw InputError(where, "k = " + std::to_string(k) + " not in [1, 65535]");
  if (levels < 1 || levels > 64) throw InputError(where, "L = " + std::to_string(levels) + " not in [1, 64]");
  if (scoring != 0) throw InputError(where, "scoring " + std::to_string(scoring) + " is not supported (only 0, L1 norm)");
  if (weighting != 0) throw InputError(where, "weighting " + std::to_string(weighting) + " is not supported (only 0, TF-IDF)");
  h.k = static_cast<int>(k);
  h.levels = static_cast<int>(levels);
  return h;
}

void parse_node(std::string_view line, const std::string& where, std::vector<TextNode>& nodes, const TextHeader& h) {
  const auto tokens = split_tokens(line);
  if (tokens.size() != 3 + kBytes) {
    throw InputError(where, "expected 'parent is_leaf d0 .. d31 weight' (" + std::to_string(3 + kBytes) + " fields), got " +
                                std::to_string(tokens.size()));
  }
  TextNode node;
  const long long parent = parse_int(tokens[0], where, "parent");
  const std::size_t id = nodes.size();
  if (parent < 0 || static_cast<unsigned long long>(parent) >= id) {
    throw InputError(where, "parent " + std::to_string(parent) + " of node " + std::to_string(id) + " is not an earlier node");
  }
  node.parent = static_cast<std::size_t>(parent);
  const long long leaf = parse_int(tokens[1], where, "is_leaf");
  if (leaf != 0 && leaf != 1) throw InputError(where, "is_leaf must be 0 or 1, got " + std::to_string(leaf));
  node.leaf = leaf == 1;
  for (std::size_t j = 0; j < kBytes; ++j) {
    const long long byte = parse_int(tokens[2 + j], where, "descriptor byte");
    if (byte < 0 || byte > 255) throw InputError(where, "descriptor byte " + std::to_string(byte) + " not in [0, 255]");
    node.descriptor[j] = static_cast<std::uint8_t>(byte);
  }
  node.weight = parse_double(tokens[2 + kBytes], where, "weight");
  if (node.weight < 0.0) throw InputError(where, "negative weight");
  TextNode& p = nodes[node.parent];
  if (p.leaf) throw InputError(where, "parent " + std::to_string(parent) + " is marked as a leaf");
  if (p.children.size() >= static_cast<std::size_t>(h.k)) {
    throw InputError(where, "node " + std::to_string(parent) + " gets more than k = " + std::to_string(h.k) + " children");
  }
  node.depth = p.depth + 1;
  if (node.depth > static_cast<std::size_t>(h.levels)) {
    throw InputError(where, "node " + std::to_string(id) + " lies deeper than L = " + std::to_string(h.levels) + " levels");
  }
  node.line = 0;  // set by the caller
  p.children.push_back(id);
  nodes.push_back(node);
}

// File nodes -> breadth-first tree; words numbered in file order of the leaves (as DBoW2 numbers them).
VocabularyTree text_tree(const std::vector<TextNode>& nodes, const TextHeader& h, const std::string& file) {
  if (nodes.size() < 2) throw InputError(file, "no vocabulary nodes after the header");
  std::vector<WordId> file_word(nodes.size(), kNoWord);
  WordId words = 0;
  for (std::size_t i = 1; i < nodes.size(); ++i) {
    if (!nodes[i].leaf && nodes[i].children.empty()) {
      throw InputError(at_line(file, nodes[i].line), "node " + std::to_string(i) + " is not a leaf but has no children");
    }
    if (nodes[i].leaf) file_word[i] = words++;
  }
  VocabularyTree tree;
  tree.branching = h.k;
  tree.depth_levels = h.levels;
  tree.parent = {kNoNode};
  tree.descriptors.assign(kBytes, 0);
  tree.word = {kNoWord};
  tree.word_weight.assign(words, 0.0);
  std::vector<std::size_t> order = {0};  // breadth first: new id -> file id
  std::vector<NodeId> new_id(nodes.size(), 0);
  for (std::size_t next = 0; next < order.size(); ++next) {
    for (const std::size_t child : nodes[order[next]].children) {
      new_id[child] = static_cast<NodeId>(order.size());
      order.push_back(child);
      const TextNode& c = nodes[child];
      tree.parent.push_back(new_id[order[next]]);
      tree.descriptors.insert(tree.descriptors.end(), c.descriptor, c.descriptor + kBytes);
      tree.word.push_back(file_word[child]);
      if (c.leaf) tree.word_weight[file_word[child]] = c.weight;
    }
  }
  return tree;
}

Vocabulary parse_text(const std::string& data, const std::string& file) {
  if (data.find('\0') != std::string::npos) throw InputError(file, "not a DBoW2 text vocabulary (binary data)");
  std::size_t pos = 0;
  std::size_t line_number = 0;
  const auto next_line = [&](std::string_view& line) {
    if (pos >= data.size()) return false;
    std::size_t end = data.find('\n', pos);
    if (end == std::string::npos) end = data.size();
    line = std::string_view(data).substr(pos, end - pos);
    pos = end + 1;
    ++line_number;
    return true;
  };
  std::string_view line;
  if (!next_line(line)) throw InputError(file, "empty file");
  const TextHeader header = parse_header(line, file);
  std::vector<TextNode> nodes(1);  // the root
  while (next_line(line)) {
    if (split_tokens(line).empty()) continue;  // blank lines (a trailing one, say)
    parse_node(line, at_line(file, line_number), nodes, header);
    nodes.back().line = line_number;
  }
  return checked(text_tree(nodes, header, file), file);
}

bool looks_like_text(const std::string& data) {
  const std::size_t n = std::min<std::size_t>(data.size(), 256);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<unsigned char>(data[i]);
    if (!(std::isdigit(c) || c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '.' || c == '-' || c == '+' ||
          c == 'e' || c == 'E')) {
      return false;
    }
  }
  return !data.empty();
}

}  // namespace

Vocabulary Vocabulary::load(const fs::path& file) {
  const std::string data = read_file(file);
  if (has_magic(data)) return parse_binary(data, file.string());
  if (looks_like_text(data)) return parse_text(data, file.string());
  throw InputError(file.string(), "neither a fleetslam binary vocabulary (bad magic) nor a DBoW2 text vocabulary "
                                  "(compressed? unpack it first)");
}

Vocabulary Vocabulary::load_binary(const fs::path& file) { return parse_binary(read_file(file), file.string()); }

Vocabulary Vocabulary::load_dbow2_text(const fs::path& file) { return parse_text(read_file(file), file.string()); }

void Vocabulary::save(const fs::path& file) const {
  if (empty()) throw InputError(file.string(), "cannot save an empty vocabulary");
  const VocabularyTree& t = tree_;
  Writer out;
  out.bytes(kMagic, sizeof kMagic);
  out.u32(kVersion);
  out.u32(static_cast<std::uint32_t>(kBytes));
  out.u32(static_cast<std::uint32_t>(t.branching));
  out.u32(static_cast<std::uint32_t>(t.depth_levels));
  out.u64(t.nodes());
  out.u64(t.words());
  out.u64(t.training_images);
  out.u64(t.training_descriptors);
  for (const NodeId p : t.parent) out.u32(p);
  out.bytes(t.descriptors.data(), t.descriptors.size());
  for (const WordId w : t.word) out.u32(w);
  for (const double w : t.word_weight) out.f64(w);
  out.u64(fnv1a(out.str().data(), out.str().size()));
  write_file(file, out.str());
}

void Vocabulary::save_dbow2_text(const fs::path& file) const {
  if (empty()) throw InputError(file.string(), "cannot save an empty vocabulary");
  const VocabularyTree& t = tree_;
  std::string text = std::to_string(t.branching) + " " + std::to_string(t.depth_levels) + " 0 0\n";
  char number[32];
  for (std::size_t i = 1; i < t.nodes(); ++i) {
    const bool leaf = t.word[i] != kNoWord;
    text += std::to_string(t.parent[i]) + (leaf ? " 1" : " 0");
    for (std::size_t j = 0; j < kBytes; ++j) text += " " + std::to_string(t.descriptors[i * kBytes + j]);
    std::snprintf(number, sizeof number, " %.17g\n", leaf ? t.word_weight[t.word[i]] : 0.0);
    text += number;
  }
  write_file(file, text);
}

}  // namespace fleetslam::slam
