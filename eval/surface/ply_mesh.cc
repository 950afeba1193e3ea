// ReadPlyMesh: the binary PLY meshes roadsurvey writes and reads back (simulator truth, surface mesh).
#include <cstring>
#include <fstream>
#include <sstream>

#include "eval/surface/surface_eval.h"
#include "formats/input_error.h"

namespace rs {
namespace {

int SizeOf(const std::string& type) {
  if (type == "char" || type == "uchar" || type == "int8" || type == "uint8") return 1;
  if (type == "short" || type == "ushort" || type == "int16" || type == "uint16") return 2;
  if (type == "int" || type == "uint" || type == "float" || type == "int32" || type == "uint32" || type == "float32")
    return 4;
  if (type == "double" || type == "float64") return 8;
  return 0;
}

}  // namespace

TriangleMesh ReadPlyMesh(const std::filesystem::path& path) {
  const auto fail = [&](const std::string& why) { return InputError(InputLocation::File(path.string()), why); };
  std::ifstream in(path, std::ios::binary);
  if (!in) throw fail("cannot open");
  std::string line;
  std::getline(in, line);
  if (line != "ply") throw fail("not a PLY file");
  int64_t nv = -1, nf = -1;
  int vertex_stride = 0, xyz_at[3] = {-1, -1, -1};
  std::string element, count_type, index_type;
  while (std::getline(in, line) && line != "end_header") {
    std::istringstream ls(line);
    std::string word;
    ls >> word;
    if (word == "format") {
      std::string f;
      ls >> f;
      if (f != "binary_little_endian") throw fail("only binary_little_endian PLY is read, not " + f);
    } else if (word == "element") {
      int64_t n = 0;
      ls >> element >> n;
      (element == "vertex" ? nv : nf) = n;
    } else if (word == "property" && element == "vertex") {
      std::string type, name;
      ls >> type >> name;
      if (SizeOf(type) == 0) throw fail("unsupported vertex property type " + type);
      for (int k = 0; k < 3; ++k)
        if (name == std::string(1, char('x' + k))) {
          if (type != "float" && type != "float32") throw fail("vertex " + name + " must be float");
          xyz_at[k] = vertex_stride;
        }
      vertex_stride += SizeOf(type);
    } else if (word == "property" && element == "face") {
      std::string list, name;
      ls >> list >> count_type >> index_type >> name;
      if (list != "list" || SizeOf(count_type) != 1 || SizeOf(index_type) != 4)
        throw fail("faces must be 'list uchar int' vertex indices");
    }
  }
  if (line != "end_header" || nv < 0 || nf < 0 || xyz_at[0] < 0 || xyz_at[1] < 0 || xyz_at[2] < 0)
    throw fail("PLY header without vertex x, y, z and faces");
  TriangleMesh m;
  m.vertices.resize(nv);
  std::vector<char> rec(vertex_stride);
  for (int64_t i = 0; i < nv; ++i) {
    if (!in.read(rec.data(), vertex_stride)) throw fail("cut short in vertex " + std::to_string(i));
    for (int k = 0; k < 3; ++k) {
      float v;
      std::memcpy(&v, rec.data() + xyz_at[k], 4);
      m.vertices[i][k] = v;
    }
  }
  m.faces.reserve(nf);
  for (int64_t i = 0; i < nf; ++i) {
    unsigned char n = 0;
    int32_t idx[3];
    if (!in.read(reinterpret_cast<char*>(&n), 1) || n != 3 || !in.read(reinterpret_cast<char*>(idx), 12))
      throw fail("face " + std::to_string(i) + " is cut short or not a triangle");
    for (int k = 0; k < 3; ++k)
      if (idx[k] < 0 || idx[k] >= nv) throw fail("face " + std::to_string(i) + " names a vertex out of range");
    m.faces.emplace_back(idx[0], idx[1], idx[2]);
  }
  return m;
}

}  // namespace rs
