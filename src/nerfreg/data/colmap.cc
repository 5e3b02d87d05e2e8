#include "nerfreg/data/colmap.h"

#include <cstring>
#include <sstream>

#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"

namespace nerfreg {
namespace {

struct ModelInfo {
  const char* name;
  int id;
  int num_params;
};
const ModelInfo kModels[] = {
    {"SIMPLE_PINHOLE", 0, 3}, {"PINHOLE", 1, 4}, {"SIMPLE_RADIAL", 2, 4},
    {"RADIAL", 3, 5},         {"OPENCV", 4, 8},  {"OPENCV_FISHEYE", 5, 8},
};

const ModelInfo* FindModel(const std::string& name) {
  for (const auto& m : kModels)
    if (name == m.name) return &m;
  return nullptr;
}
const ModelInfo* FindModel(int id) {
  for (const auto& m : kModels)
    if (id == m.id) return &m;
  return nullptr;
}

// Lines of a COLMAP text file without comments and blank lines, with their line numbers.
std::vector<std::pair<int, std::string>> DataLines(const std::string& path) {
  std::istringstream in(ReadFileToString(path));
  std::vector<std::pair<int, std::string>> out;
  std::string line;
  int number = 0;
  while (std::getline(in, line)) {
    ++number;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    out.push_back({number, line});
  }
  return out;
}

template <typename T>
void Parse(std::istringstream& s, T* v, const std::string& path, int line, const char* field) {
  if (!(s >> *v)) ThrowInputError(path, "line " + std::to_string(line) + " " + field, "a number");
}

// Little-endian binary reader over a whole file with bounds checks.
class BinaryReader {
 public:
  explicit BinaryReader(const std::string& path) : path_(path), data_(ReadFileToString(path)) {}
  template <typename T>
  T Read(const char* field) {
    if (pos_ + sizeof(T) > data_.size())
      ThrowInputError(path_, field, "more bytes (file truncated at " + std::to_string(pos_) + ")");
    T v;
    std::memcpy(&v, data_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::string ReadString(const char* field) {
    const size_t end = data_.find('\0', pos_);
    if (end == std::string::npos) ThrowInputError(path_, field, "a NUL-terminated string (file truncated)");
    std::string s = data_.substr(pos_, end - pos_);
    pos_ = end + 1;
    return s;
  }
  // A record count that must fit in the remaining bytes at `min_record_bytes` each.
  std::uint64_t ReadCount(const char* field, size_t min_record_bytes) {
    const auto n = Read<std::uint64_t>(field);
    if (n > (data_.size() - pos_) / std::max<size_t>(1, min_record_bytes)) {
      ThrowInputError(path_, field, "a count that fits in the file, got " + std::to_string(n));
    }
    return n;
  }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::string data_;
  size_t pos_ = 0;
};

class BinaryWriter {
 public:
  template <typename T>
  void Write(const T& v) {
    const size_t n = out_.size();
    out_.resize(n + sizeof(T));
    std::memcpy(out_.data() + n, &v, sizeof(T));
  }
  void WriteString(const std::string& s) {
    out_ += s;
    out_ += '\0';
  }
  const std::string& bytes() const { return out_; }

 private:
  std::string out_;
};

Eigen::Quaterniond QuatFromWxyz(double w, double x, double y, double z, const std::string& path,
                                const std::string& field) {
  const double norm = std::sqrt(w * w + x * x + y * y + z * z);
  if (!(norm > 1e-9) || !std::isfinite(norm)) ThrowInputError(path, field, "a non-zero quaternion QW QX QY QZ");
  return Eigen::Quaterniond(w / norm, x / norm, y / norm, z / norm);
}

}  // namespace

Camera ColmapCamera::ToCamera() const {
  const ModelInfo* m = FindModel(model);
  if (!m)
    throw InputError("COLMAP camera " + std::to_string(camera_id) + ": model " + model +
                     " is not supported (SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, OPENCV, OPENCV_FISHEYE)");
  const auto& p = params;
  Camera c;
  c.width = width;
  c.height = height;
  if (model == "SIMPLE_PINHOLE" || model == "SIMPLE_RADIAL" || model == "RADIAL") {
    c.fx = c.fy = p[0];
    c.cx = p[1];
    c.cy = p[2];
    if (model != "SIMPLE_PINHOLE") c.k1 = p[3];
    if (model == "RADIAL") c.k2 = p[4];
  } else {
    c.fx = p[0];
    c.fy = p[1];
    c.cx = p[2];
    c.cy = p[3];
    if (model == "OPENCV") {
      c.k1 = p[4];
      c.k2 = p[5];
      c.p1 = p[6];
      c.p2 = p[7];
    } else if (model == "OPENCV_FISHEYE") {
      c.model = CameraModel::kOpenCVFisheye;
      c.k1 = p[4];
      c.k2 = p[5];
      c.k3 = p[6];
      c.k4 = p[7];
    }
  }
  return c;
}

ColmapCamera ColmapCamera::FromCamera(std::uint32_t id, const Camera& c) {
  ColmapCamera out;
  out.camera_id = id;
  out.width = c.width;
  out.height = c.height;
  if (c.model == CameraModel::kOpenCVFisheye) {
    out.model = "OPENCV_FISHEYE";
    out.params = {c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.k3, c.k4};
  } else if (c.k3 != 0 || c.k4 != 0) {
    // COLMAP's FULL_OPENCV reads k4 as a rational term, not nerfstudio's r^8 coefficient.
    throw InputError("COLMAP camera " + std::to_string(id) +
                     ": radial k3, k4 (nerfstudio OPENCV) have no COLMAP model; " + "write transforms.json instead");
  } else if (c.HasDistortion()) {
    out.model = "OPENCV";
    out.params = {c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2};
  } else {
    out.model = "PINHOLE";
    out.params = {c.fx, c.fy, c.cx, c.cy};
  }
  return out;
}

bool IsColmapModelDir(const std::string& dir) {
  return FileExists(JoinPaths(dir, "cameras.txt")) || FileExists(JoinPaths(dir, "cameras.bin"));
}

ColmapModel ReadColmapModel(const std::string& dir) {
  if (FileExists(JoinPaths(dir, "cameras.txt"))) return ReadColmapText(dir);
  if (FileExists(JoinPaths(dir, "cameras.bin"))) return ReadColmapBinary(dir);
  ThrowInputError(dir, "", "a COLMAP model folder (cameras.txt or cameras.bin)");
}

ColmapModel ReadColmapText(const std::string& dir) {
  ColmapModel model;
  const std::string cam_path = JoinPaths(dir, "cameras.txt");
  for (const auto& [line, text] : DataLines(cam_path)) {
    std::istringstream s(text);
    ColmapCamera cam;
    Parse(s, &cam.camera_id, cam_path, line, "CAMERA_ID");
    if (!(s >> cam.model)) ThrowInputError(cam_path, "line " + std::to_string(line) + " MODEL", "a camera model name");
    Parse(s, &cam.width, cam_path, line, "WIDTH");
    Parse(s, &cam.height, cam_path, line, "HEIGHT");
    const ModelInfo* m = FindModel(cam.model);
    if (!m)
      ThrowInputError(cam_path, "line " + std::to_string(line) + " MODEL",
                      "SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL or OPENCV, got " + cam.model);
    cam.params.resize(m->num_params);
    for (auto& p : cam.params) Parse(s, &p, cam_path, line, "PARAMS");
    if (cam.width <= 0 || cam.height <= 0)
      ThrowInputError(cam_path, "line " + std::to_string(line) + " WIDTH/HEIGHT", "positive sizes");
    model.cameras[cam.camera_id] = cam;
  }
  const std::string img_path = JoinPaths(dir, "images.txt");
  {
    // As COLMAP reads it: a header line, then always the very next line as POINTS2D (it may be
    // empty); comments and blank lines only between images.
    std::istringstream in(ReadFileToString(img_path));
    std::string text;
    int line = 0;
    while (std::getline(in, text)) {
      ++line;
      if (!text.empty() && text.back() == '\r') text.pop_back();
      const size_t first = text.find_first_not_of(" \t");
      if (first == std::string::npos || text[first] == '#') continue;
      std::istringstream s(text);
      ColmapImage im;
      double qw, qx, qy, qz;
      Parse(s, &im.image_id, img_path, line, "IMAGE_ID");
      Parse(s, &qw, img_path, line, "QW");
      Parse(s, &qx, img_path, line, "QX");
      Parse(s, &qy, img_path, line, "QY");
      Parse(s, &qz, img_path, line, "QZ");
      Eigen::Vector3d t;
      Parse(s, &t.x(), img_path, line, "TX");
      Parse(s, &t.y(), img_path, line, "TY");
      Parse(s, &t.z(), img_path, line, "TZ");
      Parse(s, &im.camera_id, img_path, line, "CAMERA_ID");
      std::getline(s >> std::ws, im.name);
      if (im.name.empty()) ThrowInputError(img_path, "line " + std::to_string(line) + " NAME", "an image name");
      im.cam_from_world = Rigid3d(QuatFromWxyz(qw, qx, qy, qz, img_path, "line " + std::to_string(line)), t);
      if (!model.cameras.count(im.camera_id)) {
        ThrowInputError(img_path, "line " + std::to_string(line) + " CAMERA_ID", "a camera listed in cameras.txt");
      }
      if (std::getline(in, text)) {
        ++line;
        std::istringstream p(text);
        ColmapPoint2D pt;
        while (p >> pt.x) {
          if (!(p >> pt.y >> pt.point3d_id)) {
            ThrowInputError(img_path, "line " + std::to_string(line) + " POINTS2D", "X Y POINT3D_ID triples");
          }
          im.points2d.push_back(pt);
        }
        if (!p.eof()) ThrowInputError(img_path, "line " + std::to_string(line) + " POINTS2D", "numbers");
      }
      model.images[im.image_id] = std::move(im);
    }
  }
  const std::string pts_path = JoinPaths(dir, "points3D.txt");
  if (FileExists(pts_path)) {
    for (const auto& [line, text] : DataLines(pts_path)) {
      std::istringstream s(text);
      ColmapPoint3D pt;
      Parse(s, &pt.point3d_id, pts_path, line, "POINT3D_ID");
      Parse(s, &pt.xyz.x(), pts_path, line, "X");
      Parse(s, &pt.xyz.y(), pts_path, line, "Y");
      Parse(s, &pt.xyz.z(), pts_path, line, "Z");
      for (int c = 0; c < 3; ++c) {
        int v;
        Parse(s, &v, pts_path, line, "RGB");
        if (v < 0 || v > 255) ThrowInputError(pts_path, "line " + std::to_string(line) + " RGB", "0..255");
        pt.rgb[c] = static_cast<std::uint8_t>(v);
      }
      Parse(s, &pt.error, pts_path, line, "ERROR");
      ColmapTrackElement e;
      while (s >> e.image_id) {
        Parse(s, &e.point2d_idx, pts_path, line, "TRACK");
        pt.track.push_back(e);
      }
      model.points3d[pt.point3d_id] = std::move(pt);
    }
  }
  return model;
}

ColmapModel ReadColmapBinary(const std::string& dir) {
  ColmapModel model;
  {
    BinaryReader r(JoinPaths(dir, "cameras.bin"));
    const auto n = r.ReadCount("num_cameras", 4 + 4 + 8 + 8 + 3 * 8);
    for (std::uint64_t k = 0; k < n; ++k) {
      ColmapCamera cam;
      cam.camera_id = r.Read<std::uint32_t>("camera_id");
      const int model_id = r.Read<int>("model_id");
      const ModelInfo* m = FindModel(model_id);
      if (!m)
        ThrowInputError(r.path(), "camera " + std::to_string(cam.camera_id) + " model_id",
                        "0-4 (SIMPLE_PINHOLE..OPENCV), got " + std::to_string(model_id));
      cam.model = m->name;
      const auto w = r.Read<std::uint64_t>("width"), h = r.Read<std::uint64_t>("height");
      if (w == 0 || h == 0 || w > 65536 || h > 65536)
        ThrowInputError(r.path(), "camera " + std::to_string(cam.camera_id) + " size", "1..65536");
      cam.width = static_cast<int>(w);
      cam.height = static_cast<int>(h);
      cam.params.resize(m->num_params);
      for (auto& p : cam.params) p = r.Read<double>("params");
      model.cameras[cam.camera_id] = cam;
    }
  }
  {
    BinaryReader r(JoinPaths(dir, "images.bin"));
    const auto n = r.ReadCount("num_reg_images", 4 + 7 * 8 + 4 + 1 + 8);
    for (std::uint64_t k = 0; k < n; ++k) {
      ColmapImage im;
      im.image_id = r.Read<std::uint32_t>("image_id");
      double q[4];
      for (double& v : q) v = r.Read<double>("qvec");
      Eigen::Vector3d t;
      for (int c = 0; c < 3; ++c) t(c) = r.Read<double>("tvec");
      im.cam_from_world =
          Rigid3d(QuatFromWxyz(q[0], q[1], q[2], q[3], r.path(), "image " + std::to_string(im.image_id) + " qvec"), t);
      im.camera_id = r.Read<std::uint32_t>("camera_id");
      if (!model.cameras.count(im.camera_id))
        ThrowInputError(r.path(), "image " + std::to_string(im.image_id) + " camera_id", "a camera in cameras.bin");
      im.name = r.ReadString("name");
      const auto np = r.ReadCount("num_points2D", 24);
      im.points2d.resize(np);
      for (auto& p : im.points2d) {
        p.x = r.Read<double>("points2D");
        p.y = r.Read<double>("points2D");
        p.point3d_id = r.Read<std::int64_t>("points2D");
      }
      model.images[im.image_id] = std::move(im);
    }
  }
  const std::string pts_path = JoinPaths(dir, "points3D.bin");
  if (FileExists(pts_path)) {
    BinaryReader r(pts_path);
    const auto n = r.ReadCount("num_points3D", 8 + 24 + 3 + 8 + 8);
    for (std::uint64_t k = 0; k < n; ++k) {
      ColmapPoint3D pt;
      pt.point3d_id = r.Read<std::uint64_t>("point3D_id");
      for (int c = 0; c < 3; ++c) pt.xyz(c) = r.Read<double>("xyz");
      for (int c = 0; c < 3; ++c) pt.rgb[c] = r.Read<std::uint8_t>("rgb");
      pt.error = r.Read<double>("error");
      const auto len = r.ReadCount("track_length", 8);
      pt.track.resize(len);
      for (auto& e : pt.track) {
        e.image_id = r.Read<std::uint32_t>("track");
        e.point2d_idx = r.Read<std::uint32_t>("track");
      }
      model.points3d[pt.point3d_id] = std::move(pt);
    }
  }
  return model;
}

void WriteColmapText(const ColmapModel& model, const std::string& dir) {
  CreateDirectories(dir);
  std::ostringstream c;
  c.precision(17);
  c << "# Camera list with one line of data per camera:\n#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n";
  c << "# Number of cameras: " << model.cameras.size() << "\n";
  for (const auto& [id, cam] : model.cameras) {
    c << id << " " << cam.model << " " << cam.width << " " << cam.height;
    for (double p : cam.params) c << " " << p;
    c << "\n";
  }
  std::ostringstream i;
  i.precision(17);
  i << "# Image list with two lines of data per image:\n#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
       "#   POINTS2D[] as (X, Y, POINT3D_ID)\n";
  i << "# Number of images: " << model.images.size() << "\n";
  for (const auto& [id, im] : model.images) {
    const auto& q = im.cam_from_world.rotation;
    const auto& t = im.cam_from_world.translation;
    i << id << " " << q.w() << " " << q.x() << " " << q.y() << " " << q.z() << " " << t.x() << " " << t.y() << " "
      << t.z() << " " << im.camera_id << " " << im.name << "\n";
    for (size_t k = 0; k < im.points2d.size(); ++k) {
      const auto& p = im.points2d[k];
      i << (k ? " " : "") << p.x << " " << p.y << " " << p.point3d_id;
    }
    i << "\n";
  }
  std::ostringstream p;
  p.precision(17);
  p << "# 3D point list with one line of data per point:\n"
       "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n";
  p << "# Number of points: " << model.points3d.size() << "\n";
  for (const auto& [id, pt] : model.points3d) {
    p << id << " " << pt.xyz.x() << " " << pt.xyz.y() << " " << pt.xyz.z() << " " << int(pt.rgb[0]) << " "
      << int(pt.rgb[1]) << " " << int(pt.rgb[2]) << " " << pt.error;
    for (const auto& e : pt.track) p << " " << e.image_id << " " << e.point2d_idx;
    p << "\n";
  }
  WriteFileAtomic(JoinPaths(dir, "cameras.txt"), c.str());
  WriteFileAtomic(JoinPaths(dir, "images.txt"), i.str());
  WriteFileAtomic(JoinPaths(dir, "points3D.txt"), p.str());
}

void WriteColmapBinary(const ColmapModel& model, const std::string& dir) {
  CreateDirectories(dir);
  BinaryWriter c;
  c.Write<std::uint64_t>(model.cameras.size());
  for (const auto& [id, cam] : model.cameras) {
    const ModelInfo* m = FindModel(cam.model);
    if (!m || static_cast<int>(cam.params.size()) != m->num_params)
      throw std::invalid_argument("WriteColmapBinary: bad camera " + std::to_string(id));
    c.Write<std::uint32_t>(id);
    c.Write<int>(m->id);
    c.Write<std::uint64_t>(cam.width);
    c.Write<std::uint64_t>(cam.height);
    for (double v : cam.params) c.Write<double>(v);
  }
  BinaryWriter i;
  i.Write<std::uint64_t>(model.images.size());
  for (const auto& [id, im] : model.images) {
    i.Write<std::uint32_t>(id);
    const auto& q = im.cam_from_world.rotation;
    for (double v : {q.w(), q.x(), q.y(), q.z()}) i.Write<double>(v);
    for (int k = 0; k < 3; ++k) i.Write<double>(im.cam_from_world.translation(k));
    i.Write<std::uint32_t>(im.camera_id);
    i.WriteString(im.name);
    i.Write<std::uint64_t>(im.points2d.size());
    for (const auto& p : im.points2d) {
      i.Write<double>(p.x);
      i.Write<double>(p.y);
      i.Write<std::int64_t>(p.point3d_id);
    }
  }
  BinaryWriter p;
  p.Write<std::uint64_t>(model.points3d.size());
  for (const auto& [id, pt] : model.points3d) {
    p.Write<std::uint64_t>(id);
    for (int k = 0; k < 3; ++k) p.Write<double>(pt.xyz(k));
    for (int k = 0; k < 3; ++k) p.Write<std::uint8_t>(pt.rgb[k]);
    p.Write<double>(pt.error);
    p.Write<std::uint64_t>(pt.track.size());
    for (const auto& e : pt.track) {
      p.Write<std::uint32_t>(e.image_id);
      p.Write<std::uint32_t>(e.point2d_idx);
    }
  }
  WriteFileAtomic(JoinPaths(dir, "cameras.bin"), c.bytes());
  WriteFileAtomic(JoinPaths(dir, "images.bin"), i.bytes());
  WriteFileAtomic(JoinPaths(dir, "points3D.bin"), p.bytes());
}

Dataset DatasetFromColmap(const ColmapModel& model, const std::string& image_root) {
  Dataset d;
  d.root = image_root;
  for (const auto& [id, im] : model.images) {
    Frame f;
    f.file_path = im.name;
    f.name = im.name;
    f.camera = model.cameras.at(im.camera_id).ToCamera();
    f.cam_from_world = im.cam_from_world;
    d.frames.push_back(std::move(f));
  }
  return d;
}

ColmapModel ColmapFromDataset(const Dataset& dataset) {
  ColmapModel model;
  std::uint32_t next_camera = 1, next_image = 1;
  for (const auto& f : dataset.frames) {
    // Share one camera among frames with identical intrinsics (COLMAP's usual layout).
    std::uint32_t camera_id = 0;
    for (const auto& [id, cam] : model.cameras) {
      const ColmapCamera candidate = ColmapCamera::FromCamera(id, f.camera);
      if (candidate.model == cam.model && candidate.params == cam.params && cam.width == candidate.width &&
          cam.height == candidate.height) {
        camera_id = id;
        break;
      }
    }
    if (camera_id == 0) {
      camera_id = next_camera++;
      model.cameras[camera_id] = ColmapCamera::FromCamera(camera_id, f.camera);
    }
    ColmapImage im;
    im.image_id = next_image++;
    im.camera_id = camera_id;
    im.name = f.name;
    im.cam_from_world = f.cam_from_world;
    model.images[im.image_id] = std::move(im);
  }
  return model;
}

}  // namespace nerfreg
