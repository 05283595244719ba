#include <algorithm>
#include <array>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <string_view>
#include <unordered_map>

#include "tsdf_mcl/core/little_endian.hpp"
#include "ply_format.hpp"
#include "tsdf_mcl/core/atomic_file.hpp"
#include "tsdf_mcl/core/error.hpp"
#include "tsdf_mcl/core/input_file.hpp"
#include "tsdf_mcl/core/limits.hpp"
#include "tsdf_mcl/io/mesh.hpp"

namespace tsdf_mcl {
namespace fs = std::filesystem;
using io::ply_size;
using io::PlyElement;
using io::PlyFormat;
using io::PlyHeader;
using io::PlyProperty;
using io::PlyType;

void TriangleMesh::append(const TriangleMesh& other) {
  const int offset = static_cast<int>(vertices.size());
  vertices.insert(vertices.end(), other.vertices.begin(), other.vertices.end());
  triangles.reserve(triangles.size() + other.triangles.size());
  for (const Eigen::Vector3i& t : other.triangles) triangles.push_back(t.array() + offset);
}

Eigen::Vector3f TriangleMesh::min_corner() const {
  if (vertices.empty()) return Eigen::Vector3f::Zero();
  Eigen::Vector3f lo = vertices.front();
  for (const Eigen::Vector3f& v : vertices) lo = lo.cwiseMin(v);
  return lo;
}

Eigen::Vector3f TriangleMesh::max_corner() const {
  if (vertices.empty()) return Eigen::Vector3f::Zero();
  Eigen::Vector3f hi = vertices.front();
  for (const Eigen::Vector3f& v : vertices) hi = hi.cwiseMax(v);
  return hi;
}

namespace {

std::string read_whole_file(const fs::path& file) {
  std::string data = read_input_file(file, "mesh", limits::kMaxMeshFileBytes);
  if (data.empty()) throw Error(file.string() + ": empty file");
  return data;
}

bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }

// from_chars rejects a leading '+', which some exporters write.
bool parse_number(std::string_view token, double& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && end == token.data() + token.size();
}

bool parse_integer(std::string_view token, long long& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && end == token.data() + token.size();
}

// Whitespace-separated tokens of a text file, tracking line numbers for error messages.
class Tokens {
 public:
  Tokens(std::string_view text, std::size_t pos) : text_(text), pos_(pos) {
    for (std::size_t i = 0; i < pos; ++i) line_ += text[i] == '\n';
  }
  std::string_view next() {
    while (pos_ < text_.size() && is_space(text_[pos_])) line_ += text_[pos_++] == '\n';
    const std::size_t begin = pos_;
    while (pos_ < text_.size() && !is_space(text_[pos_])) ++pos_;
    return text_.substr(begin, pos_ - begin);
  }
  void skip_line() {
    while (pos_ < text_.size() && text_[pos_] != '\n') ++pos_;
  }
  std::size_t line() const { return line_; }

 private:
  std::string_view text_;
  std::size_t pos_;
  std::size_t line_ = 1;
};

std::string at_line(const fs::path& file, std::size_t line) {
  return file.string() + ":" + std::to_string(line) + ": ";
}

void check_finite(const Eigen::Vector3f& v, const fs::path& file, const std::string& where) {
  if (!v.allFinite()) throw Error(file.string() + ": non-finite vertex coordinate (" + where + ")");
}

// STL stores every triangle with its own three corners; merging exact duplicates makes the mesh indexed, which
// the pseudo-normals of edges and vertices need.
class VertexMerger {
 public:
  explicit VertexMerger(TriangleMesh& mesh) : mesh_(mesh) {}
  int index_of(const Eigen::Vector3f& v) {
    // +0.0f folds -0.0 into +0.0 so that both spellings of zero merge.
    const Eigen::Vector3f p = v.array() + 0.0f;
    Key key;
    std::memcpy(key.data(), p.data(), sizeof(key));
    const auto [it, inserted] = index_.try_emplace(key, static_cast<int>(mesh_.vertices.size()));
    if (inserted) mesh_.vertices.push_back(p);
    return it->second;
  }

 private:
  using Key = std::array<std::uint32_t, 3>;
  struct KeyHash {
    std::size_t operator()(const Key& k) const {
      std::uint64_t h = k[0] * 0x9E3779B97F4A7C15ull;
      h ^= (h >> 29) ^ (k[1] * 0xBF58476D1CE4E5B9ull);
      h ^= (h >> 31) ^ (k[2] * 0x94D049BB133111EBull);
      return static_cast<std::size_t>(h ^ (h >> 32));
    }
  };
  TriangleMesh& mesh_;
  std::unordered_map<Key, int, KeyHash> index_;
};

TriangleMesh parse_binary_stl(const std::string& data, std::size_t count, const fs::path& file) {
  TriangleMesh mesh;
  mesh.triangles.reserve(count);
  VertexMerger merger(mesh);
  const auto* bytes = reinterpret_cast<const unsigned char*>(data.data());
  for (std::size_t t = 0; t < count; ++t) {
    const unsigned char* record = bytes + 84 + 50 * t;
    Eigen::Vector3i tri;
    for (int k = 0; k < 3; ++k) {
      const unsigned char* corner = record + 12 + 12 * k;
      const Eigen::Vector3f v(io::load<float>(corner, true), io::load<float>(corner + 4, true),
                              io::load<float>(corner + 8, true));
      check_finite(v, file, "triangle " + std::to_string(t));
      tri[k] = merger.index_of(v);
    }
    mesh.triangles.push_back(tri);
  }
  return mesh;
}

TriangleMesh parse_ascii_stl(const std::string& data, const fs::path& file) {
  TriangleMesh mesh;
  VertexMerger merger(mesh);
  Tokens tokens(data, 0);
  tokens.next();       // "solid"
  tokens.skip_line();  // the solid's name may contain spaces
  auto expect = [&](std::string_view word) {
    const std::string_view got = tokens.next();
    if (got.empty())
      throw Error(at_line(file, tokens.line()) + "ASCII STL ends early (truncated): expected '" + std::string(word) +
                  "'");
    if (got != word) {
      throw Error(at_line(file, tokens.line()) + "malformed ASCII STL: expected '" + std::string(word) + "', got '" +
                  std::string(got) + "'");
    }
  };
  auto number = [&]() {
    const std::string_view got = tokens.next();
    double value = 0.0;
    if (got.empty()) throw Error(at_line(file, tokens.line()) + "ASCII STL ends early (truncated) inside a facet");
    if (!parse_number(got, value)) {
      throw Error(at_line(file, tokens.line()) + "malformed ASCII STL: expected a number, got '" + std::string(got) +
                  "'");
    }
    return static_cast<float>(value);
  };
  bool ended = false;
  std::vector<int> loop;
  for (std::string_view word = tokens.next(); !word.empty(); word = tokens.next()) {
    if (word == "endsolid") {
      tokens.skip_line();
      ended = true;
      continue;
    }
    if (word == "solid" && ended) {  // several solids in one file
      tokens.skip_line();
      ended = false;
      continue;
    }
    if (word != "facet" || ended) {
      throw Error(at_line(file, tokens.line()) + "malformed ASCII STL: expected 'facet', got '" + std::string(word) +
                  "'");
    }
    expect("normal");
    for (int k = 0; k < 3; ++k) number();
    expect("outer");
    expect("loop");
    loop.clear();
    for (std::string_view v = tokens.next(); v != "endloop"; v = tokens.next()) {
      if (v.empty()) throw Error(at_line(file, tokens.line()) + "ASCII STL ends early (truncated) inside a facet");
      if (v != "vertex") {
        throw Error(at_line(file, tokens.line()) + "malformed ASCII STL: expected 'vertex', got '" + std::string(v) +
                    "'");
      }
      // Separate statements: the order in which function arguments are evaluated is unspecified.
      const float x = number();
      const float y = number();
      const float z = number();
      const Eigen::Vector3f p(x, y, z);
      check_finite(p, file, "line " + std::to_string(tokens.line()));
      loop.push_back(merger.index_of(p));
    }
    if (loop.size() < 3) throw Error(at_line(file, tokens.line()) + "facet with fewer than 3 vertices");
    expect("endfacet");
    for (std::size_t k = 1; k + 1 < loop.size(); ++k) mesh.triangles.emplace_back(loop[0], loop[k], loop[k + 1]);
  }
  if (!ended) throw Error(file.string() + ": ASCII STL has no 'endsolid' (truncated)");
  return mesh;
}

TriangleMesh parse_stl(const std::string& data, const fs::path& file) {
  // A binary STL may begin with "solid" too, so the size rule (84-byte header + 50 bytes per triangle) decides
  // first; ASCII text at bytes 80..83 would claim hundreds of millions of triangles and never match.
  if (data.size() >= 84) {
    const std::size_t count = io::load<std::uint32_t>(reinterpret_cast<const unsigned char*>(data.data()) + 80, true);
    if (84 + 50 * static_cast<std::uint64_t>(count) == data.size()) return parse_binary_stl(data, count, file);
  }
  std::size_t first = 0;
  while (first < data.size() && is_space(data[first])) ++first;
  if (data.compare(first, 5, "solid") == 0) return parse_ascii_stl(data, file);
  if (data.size() < 84) {
    throw Error(file.string() + ": " + std::to_string(data.size()) +
                " bytes is too short for a binary STL (84-byte header) and the file is not ASCII STL");
  }
  const std::size_t count = io::load<std::uint32_t>(reinterpret_cast<const unsigned char*>(data.data()) + 80, true);
  throw Error(file.string() + ": binary STL header says " + std::to_string(count) + " triangles (" +
              std::to_string(84 + 50 * static_cast<std::uint64_t>(count)) + " bytes) but the file has " +
              std::to_string(data.size()) + " bytes (truncated or corrupt)");
}

// ---------------------------------------------------------------------------------------------------- PLY

// Reads the values of a PLY body one at a time, in whichever of the three encodings the header named.
class PlyValues {
 public:
  PlyValues(const std::string& data, std::size_t body, PlyFormat format, const fs::path& file)
      : data_(data), pos_(body), format_(format), file_(file), tokens_(data, body) {}

  double next(PlyType type, const PlyElement& element, std::size_t row) {
    if (format_ == PlyFormat::kAscii) {
      const std::string_view token = tokens_.next();
      double value = 0.0;
      if (token.empty()) throw Error(file_.string() + ": PLY data ends early (truncated) in " + where(element, row));
      if (!parse_number(token, value)) {
        throw Error(at_line(file_, tokens_.line()) + "malformed PLY value '" + std::string(token) + "' in " +
                    where(element, row));
      }
      return value;
    }
    const std::size_t size = ply_size(type);
    if (pos_ + size > data_.size()) {
      throw Error(file_.string() + ": PLY data ends early (truncated) in " + where(element, row));
    }
    const auto* p = reinterpret_cast<const unsigned char*>(data_.data()) + pos_;
    pos_ += size;
    return io::ply_value(type, p, format_ == PlyFormat::kBinaryLittle);
  }

  static std::string where(const PlyElement& element, std::size_t row) {
    return "element " + element.name + " " + std::to_string(row);
  }

 private:
  const std::string& data_;
  std::size_t pos_;
  PlyFormat format_;
  const fs::path& file_;
  Tokens tokens_;
};

// Where a PLY mesh's values are: the vertex and face elements, the x, y, z properties, the faces' index list.
struct PlyMeshLayout {
  const PlyElement* vertex = nullptr;
  const PlyElement* face = nullptr;
  int xyz[3] = {-1, -1, -1};
  int indices_property = -1;
};

PlyMeshLayout ply_mesh_layout(const std::vector<PlyElement>& elements, const fs::path& file) {
  PlyMeshLayout l;
  for (const PlyElement& e : elements) {
    if (e.name == "vertex") l.vertex = &e;
    if (e.name == "face") l.face = &e;
  }
  if (!l.vertex) throw Error(file.string() + ": PLY has no vertex element");
  if (!l.face) throw Error(file.string() + ": PLY has no face element (a point cloud, not a mesh)");
  for (std::size_t k = 0; k < l.vertex->properties.size(); ++k) {
    const PlyProperty& p = l.vertex->properties[k];
    for (int a = 0; a < 3; ++a) {
      if (p.name == std::string(1, static_cast<char>('x' + a)) && !p.is_list) l.xyz[a] = static_cast<int>(k);
    }
  }
  if (l.xyz[0] < 0 || l.xyz[1] < 0 || l.xyz[2] < 0) throw Error(file.string() + ": PLY vertices lack x, y or z");
  for (std::size_t k = 0; k < l.face->properties.size(); ++k) {
    const PlyProperty& p = l.face->properties[k];
    if (p.is_list && (p.name == "vertex_indices" || p.name == "vertex_index")) l.indices_property = static_cast<int>(k);
  }
  if (l.indices_property < 0) throw Error(file.string() + ": PLY faces have no vertex_indices list");
  return l;
}

// Every row takes at least a byte per value in binary files and two (a digit and a separator) in ascii ones:
// counts the rest of the file cannot hold are corrupt, and must not size memory or loops.
void check_ply_body_size(const PlyHeader& header, std::size_t body_bytes, const fs::path& file) {
  std::uint64_t min_bytes = 0;
  const std::uint64_t per_value = header.format == PlyFormat::kAscii ? 2 : 1;
  for (const PlyElement& e : header.elements) {
    std::uint64_t row = 0;
    for (const PlyProperty& p : e.properties)
      row += per_value * (header.format == PlyFormat::kAscii ? 1 : ply_size(p.is_list ? p.count_type : p.type));
    if (row == 0 && e.count > 0) throw Error(file.string() + ": PLY element " + e.name + " has rows but no properties");
    min_bytes += row * e.count;  // at most 2^28 rows of at most 4 * 256 bytes: no overflow
  }
  if (min_bytes > body_bytes + 1) {
    throw Error(file.string() + ": PLY header announces at least " + std::to_string(min_bytes) +
                " bytes of elements, the file has " + std::to_string(body_bytes) +
                " after the header (truncated or corrupt)");
  }
}

// One list property of a row; a face's index list becomes triangles (a fan), any other list is skipped.
void read_ply_list(PlyValues& values, const PlyElement& e, std::size_t row, const PlyProperty& p, bool keep,
                   std::vector<long long>& polygon, TriangleMesh& mesh, const fs::path& file) {
  const double n = values.next(p.count_type, e, row);
  if (!(n >= 0) || n != std::floor(n) || n > 1e6)
    throw Error(file.string() + ": bad PLY list length in " + PlyValues::where(e, row));
  if (keep) polygon.clear();
  for (long long i = 0; i < static_cast<long long>(n); ++i) {
    const double v = values.next(p.type, e, row);
    if (!keep) continue;
    if (v != std::floor(v) || v < 0 || v > static_cast<double>(std::numeric_limits<int>::max())) {
      throw Error(file.string() + ": PLY vertex index " + std::to_string(v) + " is not valid in " +
                  PlyValues::where(e, row));
    }
    polygon.push_back(static_cast<long long>(v));
  }
  if (!keep) return;
  if (polygon.size() < 3)
    throw Error(file.string() + ": PLY face with fewer than 3 vertices in " + PlyValues::where(e, row));
  for (std::size_t i = 1; i + 1 < polygon.size(); ++i) {
    mesh.triangles.emplace_back(static_cast<int>(polygon[0]), static_cast<int>(polygon[i]),
                                static_cast<int>(polygon[i + 1]));
  }
}

// Every element's rows in file order: the vertices' x, y, z and the faces' index lists kept, the rest read past.
void read_ply_elements(PlyValues& values, const std::vector<PlyElement>& elements, const PlyMeshLayout& l,
                       TriangleMesh& mesh, const fs::path& file) {
  std::vector<long long> polygon;
  for (const PlyElement& e : elements) {
    const bool is_vertex = &e == l.vertex;
    const bool is_face = &e == l.face;
    for (std::size_t row = 0; row < e.count; ++row) {
      double coord[3] = {0, 0, 0};
      for (std::size_t k = 0; k < e.properties.size(); ++k) {
        const PlyProperty& p = e.properties[k];
        if (p.is_list) {
          read_ply_list(values, e, row, p, is_face && static_cast<int>(k) == l.indices_property, polygon, mesh, file);
          continue;
        }
        const double v = values.next(p.type, e, row);
        for (int a = 0; a < 3; ++a) {
          if (is_vertex && l.xyz[a] == static_cast<int>(k)) coord[a] = v;
        }
      }
      if (is_vertex) {
        const Eigen::Vector3f v(static_cast<float>(coord[0]), static_cast<float>(coord[1]),
                                static_cast<float>(coord[2]));
        check_finite(v, file, "vertex " + std::to_string(row));
        mesh.vertices.push_back(v);
      }
    }
  }
}

TriangleMesh parse_ply(const std::string& data, const fs::path& file) {
  std::size_t pos = 0;
  const PlyHeader header = io::parse_ply_header(
      [&](std::string& line) {
        if (pos >= data.size()) return false;
        std::size_t eol = data.find('\n', pos);
        if (eol == std::string::npos) eol = data.size();
        line.assign(data, pos, eol - pos);
        pos = std::min(eol + 1, data.size());
        return true;
      },
      file.string(), limits::kMaxMeshElements);
  const PlyMeshLayout layout = ply_mesh_layout(header.elements, file);
  check_ply_body_size(header, data.size() - pos, file);
  TriangleMesh mesh;
  mesh.vertices.reserve(layout.vertex->count);
  mesh.triangles.reserve(layout.face->count);
  PlyValues values(data, pos, header.format, file);
  read_ply_elements(values, header.elements, layout, mesh, file);
  const auto n = static_cast<int>(mesh.vertices.size());
  for (std::size_t t = 0; t < mesh.triangles.size(); ++t) {
    if ((mesh.triangles[t].array() >= n).any()) {
      throw Error(file.string() + ": PLY face index " + std::to_string(mesh.triangles[t].maxCoeff()) +
                  " out of range (" + std::to_string(n) + " vertices)");
    }
  }
  return mesh;
}

TriangleMesh parse_obj(const std::string& data, const fs::path& file) {
  TriangleMesh mesh;
  std::vector<long long> polygon;
  std::size_t pos = 0;
  std::size_t line_no = 0;
  while (pos < data.size()) {
    std::size_t eol = data.find('\n', pos);
    if (eol == std::string::npos) eol = data.size();
    std::string_view line(data.data() + pos, eol - pos);
    pos = eol + 1;
    ++line_no;
    if (const std::size_t hash = line.find('#'); hash != std::string_view::npos) line = line.substr(0, hash);
    Tokens words(line, 0);
    const std::string_view key = words.next();
    if (key == "v") {
      double c[3];
      for (double& x : c) {
        const std::string_view token = words.next();
        if (!parse_number(token, x)) {
          throw Error(at_line(file, line_no) + "malformed OBJ vertex: expected a number, got '" + std::string(token) +
                      "'");
        }
      }
      const Eigen::Vector3f v(static_cast<float>(c[0]), static_cast<float>(c[1]), static_cast<float>(c[2]));
      check_finite(v, file, "line " + std::to_string(line_no));
      mesh.vertices.push_back(v);
    } else if (key == "f") {
      polygon.clear();
      for (std::string_view ref = words.next(); !ref.empty(); ref = words.next()) {
        // v, v/vt, v//vn, v/vt/vn: only the position index matters here.
        const std::string_view position = ref.substr(0, ref.find('/'));
        long long index = 0;
        if (!parse_integer(position, index) || index == 0) {
          throw Error(at_line(file, line_no) + "malformed OBJ face vertex '" + std::string(ref) + "'");
        }
        // Negative indices count back from the last vertex defined so far.
        if (index < 0)
          index += static_cast<long long>(mesh.vertices.size());
        else
          index -= 1;
        if (index < 0)
          throw Error(at_line(file, line_no) + "OBJ face vertex '" + std::string(ref) +
                      "' refers before the first vertex");
        if (index > std::numeric_limits<int>::max()) throw Error(at_line(file, line_no) + "OBJ face index too large");
        polygon.push_back(index);
      }
      if (polygon.size() < 3) throw Error(at_line(file, line_no) + "OBJ face with fewer than 3 vertices");
      for (std::size_t i = 1; i + 1 < polygon.size(); ++i) {
        mesh.triangles.emplace_back(static_cast<int>(polygon[0]), static_cast<int>(polygon[i]),
                                    static_cast<int>(polygon[i + 1]));
      }
    }
  }
  // Positive indices may name vertices defined later in the file, so the range is checked at the end.
  const auto n = static_cast<int>(mesh.vertices.size());
  for (const Eigen::Vector3i& t : mesh.triangles) {
    if ((t.array() >= n).any()) {
      throw Error(file.string() + ": OBJ face index " + std::to_string(t.maxCoeff() + 1) + " out of range (" +
                  std::to_string(n) + " vertices)");
    }
  }
  return mesh;
}

std::string lower_extension(const fs::path& file) {
  std::string ext = file.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext;
}

}  // namespace

TriangleMesh load_mesh(const fs::path& file) {
  const std::string ext = lower_extension(file);
  if (ext != ".stl" && ext != ".ply" && ext != ".obj") {
    throw Error("mesh " + file.string() + ": unknown extension '" + ext + "' (expected .stl, .ply or .obj)");
  }
  const std::string data = read_whole_file(file);
  TriangleMesh mesh = ext == ".stl"   ? parse_stl(data, file)
                      : ext == ".ply" ? parse_ply(data, file)
                                      : parse_obj(data, file);
  if (mesh.triangles.empty()) throw Error(file.string() + ": mesh has no triangles");
  return mesh;
}

void save_mesh_ply(const TriangleMesh& mesh, const fs::path& file) {
  std::string out = "ply\nformat binary_little_endian 1.0\ncomment written by tsdf-mcl\nelement vertex " +
                    std::to_string(mesh.vertices.size()) +
                    "\nproperty float x\nproperty float y\nproperty float z\nelement face " +
                    std::to_string(mesh.triangles.size()) + "\nproperty list uchar int vertex_indices\nend_header\n";
  out.reserve(out.size() + mesh.vertices.size() * 12 + mesh.triangles.size() * 13);
  for (const Eigen::Vector3f& v : mesh.vertices) {
    for (int a = 0; a < 3; ++a) io::append_le(out, v[a]);
  }
  for (const Eigen::Vector3i& t : mesh.triangles) {
    out.push_back(3);
    for (int a = 0; a < 3; ++a) io::append_le(out, static_cast<std::int32_t>(t[a]));
  }
  write_file_atomically(file, out, "mesh");
}

}  // namespace tsdf_mcl
