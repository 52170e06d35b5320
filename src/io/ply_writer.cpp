#include "io/ply_writer.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <memory>
#include <sstream>

#include "io/durable_file.h"

namespace ef {

namespace {

// Little-endian stores independent of the host byte order.
inline unsigned char* put_u32(unsigned char* p, uint32_t v) {
  p[0] = static_cast<unsigned char>(v);
  p[1] = static_cast<unsigned char>(v >> 8);
  p[2] = static_cast<unsigned char>(v >> 16);
  p[3] = static_cast<unsigned char>(v >> 24);
  return p + 4;
}
inline unsigned char* put_f32(unsigned char* p, float f) {
  uint32_t v;
  std::memcpy(&v, &f, 4);
  return put_u32(p, v);
}
inline float col_f(const Column<float>& c, std::size_t i) { return c.data ? c[i] : 0.0f; }
inline uint8_t col_u8(const Column<uint8_t>& c, std::size_t i) { return c.data ? c[i] : uint8_t{0}; }

struct FileCloser {
  void operator()(std::FILE* f) const {
    if (f) std::fclose(f);
  }
};

}  // namespace

Status write_surfel_ply(const std::string& path, const SurfelCloudView& cloud, const std::string& comment) {
  if (cloud.count > 0 && (!cloud.x.data || !cloud.y.data || !cloud.z.data))
    return error(ErrorCode::kInvalidArgument, path + ": surfel view without x, y, z columns");
  if (comment.find_first_of("\r\n") != std::string::npos)
    return error(ErrorCode::kInvalidArgument, path + ": PLY comment must be a single line");
  // Written as <path>.partial and renamed into place once whole and synced: a crash or a full disk
  // leaves the earlier map (or none), never a header promising more vertices than follow.
  FileReplacement replacement(path);
  std::unique_ptr<std::FILE, FileCloser> f(std::fopen(replacement.temp_path().c_str(), "wb"));
  if (!f) return error(ErrorCode::kIoError, path + ": cannot create: " + std::strerror(errno));
  std::string header = "ply\nformat binary_little_endian 1.0\ncomment EdgeFusion surfel map\n";
  if (!comment.empty()) header += "comment " + comment + "\n";
  header += "element vertex " + std::to_string(cloud.count) + "\n";
  header +=
      "property float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      "property float radius\nproperty float confidence\n";
  const bool classes = cloud.class_id.data != nullptr;
  if (classes) header += "property uchar class_id\nproperty float class_prob\n";
  header += "end_header\n";
  if (std::fwrite(header.data(), 1, header.size(), f.get()) != header.size())
    return error(ErrorCode::kIoError, path + ": header write failed: " + std::strerror(errno));

  constexpr std::size_t kPerChunk = 65536 / kPlySurfelRecordBytes;
  static_assert(kPerChunk > 0, "chunk");
  unsigned char buf[kPerChunk * kPlySurfelRecordBytes];
  std::size_t i = 0;
  while (i < cloud.count) {
    const std::size_t n = std::min(kPerChunk, cloud.count - i);
    unsigned char* p = buf;
    for (std::size_t k = 0; k < n; ++k, ++i) {
      p = put_f32(p, cloud.x[i]);
      p = put_f32(p, cloud.y[i]);
      p = put_f32(p, cloud.z[i]);
      p = put_f32(p, col_f(cloud.nx, i));
      p = put_f32(p, col_f(cloud.ny, i));
      p = put_f32(p, col_f(cloud.nz, i));
      *p++ = col_u8(cloud.red, i);
      *p++ = col_u8(cloud.green, i);
      *p++ = col_u8(cloud.blue, i);
      p = put_f32(p, col_f(cloud.radius, i));
      p = put_f32(p, col_f(cloud.confidence, i));
      if (classes) {
        *p++ = col_u8(cloud.class_id, i);
        p = put_f32(p, col_f(cloud.class_prob, i));
      }
    }
    const std::size_t bytes = static_cast<std::size_t>(p - buf);
    if (std::fwrite(buf, 1, bytes, f.get()) != bytes)
      return error(ErrorCode::kIoError, path + ": write failed after " + std::to_string(i - n) + " of " +
                                            std::to_string(cloud.count) + " vertices: " + std::strerror(errno));
  }
  std::FILE* raw = f.release();
  if (std::fclose(raw) != 0) return error(ErrorCode::kIoError, path + ": write failed: " + std::strerror(errno));
  return replacement.commit();
}

SurfelCloudView SurfelCloud::view() const {
  SurfelCloudView v;
  v.count = size();
  v.x = x.data();
  v.y = y.data();
  v.z = z.data();
  v.nx = nx.data();
  v.ny = ny.data();
  v.nz = nz.data();
  v.red = red.data();
  v.green = green.data();
  v.blue = blue.data();
  v.radius = radius.data();
  v.confidence = confidence.data();
  if (has_classes) {
    v.class_id = class_id.data();
    v.class_prob = class_prob.data();
  }
  return v;
}

namespace {

enum class PlyType { kInt8, kUInt8, kInt16, kUInt16, kInt32, kUInt32, kFloat32, kFloat64 };

bool parse_type(const std::string& s, PlyType& t, int& size) {
  struct Entry {
    const char* name;
    PlyType type;
    int size;
  };
  static const Entry kTypes[] = {
      {"char", PlyType::kInt8, 1},     {"int8", PlyType::kInt8, 1},       {"uchar", PlyType::kUInt8, 1},
      {"uint8", PlyType::kUInt8, 1},   {"short", PlyType::kInt16, 2},     {"int16", PlyType::kInt16, 2},
      {"ushort", PlyType::kUInt16, 2}, {"uint16", PlyType::kUInt16, 2},   {"int", PlyType::kInt32, 4},
      {"int32", PlyType::kInt32, 4},   {"uint", PlyType::kUInt32, 4},     {"uint32", PlyType::kUInt32, 4},
      {"float", PlyType::kFloat32, 4}, {"float32", PlyType::kFloat32, 4}, {"double", PlyType::kFloat64, 8},
      {"float64", PlyType::kFloat64, 8}};
  for (const Entry& e : kTypes) {
    if (s == e.name) {
      t = e.type;
      size = e.size;
      return true;
    }
  }
  return false;
}

inline uint32_t get_u32(const unsigned char* p) {
  return static_cast<uint32_t>(p[0]) | static_cast<uint32_t>(p[1]) << 8 | static_cast<uint32_t>(p[2]) << 16 |
         static_cast<uint32_t>(p[3]) << 24;
}
inline float get_f32(const unsigned char* p) {
  const uint32_t v = get_u32(p);
  float f;
  std::memcpy(&f, &v, 4);
  return f;
}

// Known properties: index into the cloud's columns.
enum Known { kX, kY, kZ, kNx, kNy, kNz, kRed, kGreen, kBlue, kRadius, kConf, kClass, kProb, kNumKnown };
const char* const kKnownNames[kNumKnown] = {"x",   "y",    "z",     "nx",     "ny",         "nz",      "red",
                                            "green", "blue", "radius", "confidence", "class_id", "class_prob"};
bool known_is_u8(int k) { return k == kRed || k == kGreen || k == kBlue || k == kClass; }

}  // namespace

Result<SurfelCloud> read_surfel_ply(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return error(ErrorCode::kNotFound, path + ": cannot open PLY file");
  std::string line;
  int line_no = 0;
  auto bad = [&](const std::string& what) {
    return error(ErrorCode::kCorruptData, path + ":" + std::to_string(line_no) + ": " + what);
  };
  auto next_line = [&]() -> bool {
    if (!std::getline(in, line)) return false;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    return true;
  };
  if (!next_line() || line != "ply") return bad("not a PLY file (first line is not 'ply')");

  struct Prop {
    int known;  // Known index or -1
    PlyType type;
    int size;
    std::size_t offset;
  };
  std::vector<Prop> props;
  std::size_t record = 0;
  long long vertex_count = -1;
  bool format_seen = false, in_vertex = false;
  int known_seen[kNumKnown] = {};
  while (true) {
    if (!next_line()) return bad("header ends without 'end_header'");
    std::istringstream ss(line);
    std::string kw;
    ss >> kw;
    if (kw == "end_header") break;
    if (kw == "comment" || kw == "obj_info" || kw.empty()) continue;
    if (kw == "format") {
      std::string fmt, ver;
      ss >> fmt >> ver;
      if (fmt != "binary_little_endian")
        return error(ErrorCode::kUnsupported, path + ":" + std::to_string(line_no) + ": format '" + fmt +
                     "' not supported (only binary_little_endian)");
      if (ver != "1.0") return bad("unsupported PLY version '" + ver + "'");
      format_seen = true;
    } else if (kw == "element") {
      std::string name;
      long long n = -1;
      ss >> name >> n;
      if (!ss || n < 0) return bad("malformed element line '" + line + "'");
      if (vertex_count < 0) {
        if (name != "vertex") return bad("first element is '" + name + "', expected 'vertex'");
        vertex_count = n;
        in_vertex = true;
      } else {
        in_vertex = false;
        if (n != 0)
          return error(ErrorCode::kUnsupported, path + ":" + std::to_string(line_no) + ": element '" + name +
                       "' with " + std::to_string(n) + " entries not supported (point clouds only)");
      }
    } else if (kw == "property") {
      if (vertex_count < 0) return bad("property before any element");
      std::string type_name, name;
      ss >> type_name;
      if (type_name == "list") {
        if (in_vertex) return error(ErrorCode::kUnsupported, path + ":" + std::to_string(line_no) +
                                                                 ": list properties on vertices not supported");
        continue;  // a list on an empty trailing element
      }
      ss >> name;
      if (name.empty()) return bad("malformed property line '" + line + "'");
      Prop p{-1, PlyType::kUInt8, 0, record};
      if (!parse_type(type_name, p.type, p.size)) return bad("unknown property type '" + type_name + "'");
      if (!in_vertex) continue;
      for (int k = 0; k < kNumKnown; ++k) {
        if (name == kKnownNames[k]) {
          if (known_seen[k]) return bad("duplicate property '" + name + "'");
          const PlyType want = known_is_u8(k) ? PlyType::kUInt8 : PlyType::kFloat32;
          if (p.type != want)
            return bad("property '" + name + "' has type '" + type_name + "', expected '" +
                       (known_is_u8(k) ? "uchar" : "float") + "'");
          known_seen[k] = 1;
          p.known = k;
        }
      }
      record += static_cast<std::size_t>(p.size);
      props.push_back(p);
    } else {
      return bad("unexpected header line '" + line + "'");
    }
  }
  if (!format_seen) return bad("header has no 'format' line");
  if (vertex_count < 0) return bad("header has no 'element vertex'");
  if (!known_seen[kX] || !known_seen[kY] || !known_seen[kZ]) return bad("vertex element lacks float x, y, z");

  const std::streampos data_start = in.tellg();
  in.seekg(0, std::ios::end);
  const std::streamoff data_bytes = in.tellg() - data_start;
  in.seekg(data_start);
  // record >= 12 (x, y, z are required), so the division cannot fault and the product cannot overflow.
  const unsigned long long have = data_bytes < 0 ? 0ULL : static_cast<unsigned long long>(data_bytes);
  if (static_cast<unsigned long long>(vertex_count) > have / record) {
    return error(ErrorCode::kCorruptData, path + ": truncated: " + std::to_string(vertex_count) + " vertices of " +
                 std::to_string(record) + " bytes each, but only " + std::to_string(have) + " bytes of data");
  }
  const unsigned long long expected = static_cast<unsigned long long>(vertex_count) * record;
  if (static_cast<unsigned long long>(data_bytes) > expected) {
    return error(ErrorCode::kCorruptData, path + ": " + std::to_string(data_bytes - static_cast<std::streamoff>(expected)) +
                 " trailing bytes after " + std::to_string(vertex_count) + " vertices");
  }

  SurfelCloud c;
  const std::size_t n = static_cast<std::size_t>(vertex_count);
  std::vector<float>* fcols[kNumKnown] = {&c.x, &c.y, &c.z, &c.nx, &c.ny, &c.nz, nullptr,
                                          nullptr, nullptr, &c.radius, &c.confidence, nullptr, &c.class_prob};
  std::vector<uint8_t>* ucols[kNumKnown] = {nullptr, nullptr, nullptr, nullptr, nullptr, nullptr, &c.red,
                                            &c.green, &c.blue, nullptr, nullptr, &c.class_id, nullptr};
  for (int k = 0; k < kNumKnown; ++k) {
    if (fcols[k]) fcols[k]->assign(n, 0.0f);
    if (ucols[k]) ucols[k]->assign(n, 0);
  }
  c.has_classes = false;
  for (const Prop& p : props) c.has_classes = c.has_classes || p.known == kClass;
  std::vector<unsigned char> rec(record);
  for (std::size_t i = 0; i < n; ++i) {
    if (!in.read(reinterpret_cast<char*>(rec.data()), static_cast<std::streamsize>(record)))
      return error(ErrorCode::kIoError, path + ": read failed at vertex " + std::to_string(i));
    for (const Prop& p : props) {
      if (p.known < 0) continue;
      if (fcols[p.known]) (*fcols[p.known])[i] = get_f32(rec.data() + p.offset);
      else (*ucols[p.known])[i] = rec[p.offset];
    }
  }
  return c;
}

}  // namespace ef
