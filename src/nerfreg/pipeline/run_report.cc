#include "nerfreg/pipeline/run_report.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "nerfreg/data/transforms_json.h"
#include "nerfreg/util/error.h"
#include "nerfreg/util/file_util.h"
#include "nerfreg/util/image_metrics.h"
#include "nerfreg/util/json_util.h"
#include "nerfreg/util/report.h"

namespace fs = std::filesystem;

namespace nerfreg {

void ReportOptions::Check() const {
  if (max_points_per_block < 1) ThrowInputError("--max-points", "", "a positive number");
  if (max_views < 0) ThrowInputError("--max-views", "", "a non-negative number");
  if (max_images < 0 || max_image_bytes < 0 || max_camera_views < 0) {
    throw std::invalid_argument("ReportOptions: negative limit");
  }
}

Eigen::Matrix3Xd ReadPlyPoints(const std::string& path, int max_points) {
  const std::string text = ReadFileToString(path);
  std::istringstream in(text);
  std::string line;
  if (!std::getline(in, line) || line.rfind("ply", 0) != 0) ThrowInputError(path, "magic", "a PLY file ('ply')");
  long long vertices = -1;
  std::vector<std::string> properties;
  bool in_vertex = false, ascii = false;
  while (std::getline(in, line)) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    std::istringstream words(line);
    std::string key;
    words >> key;
    if (key == "end_header") break;
    if (key == "format") {
      std::string kind;
      words >> kind;
      ascii = kind == "ascii";
    } else if (key == "element") {
      std::string name;
      long long count = -1;
      words >> name >> count;
      in_vertex = name == "vertex";
      if (in_vertex) vertices = count;
    } else if (key == "property" && in_vertex) {
      std::string type, name;
      words >> type >> name;
      properties.push_back(name);
    }
  }
  if (!ascii) ThrowInputError(path, "format", "ascii 1.0 (as nerf export --points writes)");
  if (vertices < 0 || vertices > (1LL << 28)) ThrowInputError(path, "element vertex", "a vertex count");
  if (properties.size() < 3 || properties[0] != "x" || properties[1] != "y" || properties[2] != "z") {
    ThrowInputError(path, "property", "x y z as the first vertex properties");
  }
  const long long step = std::max<long long>(1, (vertices + max_points - 1) / std::max(1, max_points));
  Eigen::Matrix3Xd out(3, (vertices + step - 1) / step);
  for (long long i = 0, k = 0; i < vertices; ++i) {
    if (!std::getline(in, line))
      ThrowInputError(path, "vertex " + std::to_string(i), std::to_string(vertices) + " vertex lines");
    if (i % step) continue;
    std::istringstream v(line);
    double x, y, z;
    if (!(v >> x >> y >> z) || !std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) {
      ThrowInputError(path, "vertex " + std::to_string(i), "three finite numbers x y z");
    }
    out.col(k++) = Eigen::Vector3d(x, y, z);
  }
  return out;
}

Eigen::Matrix3Xd CameraFrustumSegments(const Dataset& dataset, const Sim3d& world_from_dataset, double depth) {
  Eigen::Matrix3Xd out(3, 16 * dataset.frames.size());
  Eigen::Index k = 0;
  for (const Frame& f : dataset.frames) {
    const Camera& c = f.camera;
    const Rigid3d world_from_cam = f.cam_from_world.Inverse();
    auto to_world = [&](const Eigen::Vector3d& x_in_cam) { return world_from_dataset * (world_from_cam * x_in_cam); };
    const Eigen::Vector3d apex = to_world(Eigen::Vector3d::Zero());
    Eigen::Vector3d corner[4];
    const double us[4] = {0, double(c.width), double(c.width), 0}, vs[4] = {0, 0, double(c.height), double(c.height)};
    for (int i = 0; i < 4; ++i) {
      corner[i] = to_world(depth * Eigen::Vector3d((us[i] - c.cx) / c.fx, (vs[i] - c.cy) / c.fy, 1.0));
    }
    for (int i = 0; i < 4; ++i) {
      out.col(k++) = apex;
      out.col(k++) = corner[i];
      out.col(k++) = corner[i];
      out.col(k++) = corner[(i + 1) % 4];
    }
  }
  return out;
}

Image ErrorHeatMap(const Image& render, const Image& ground_truth, float full_scale) {
  if (render.width != ground_truth.width || render.height != ground_truth.height || render.channels != 3 ||
      ground_truth.channels != 3) {
    throw std::invalid_argument("ErrorHeatMap: expects two RGB images of one size");
  }
  Image out(render.width, render.height, 3);
  const size_t n = static_cast<size_t>(render.width) * render.height;
  for (size_t i = 0; i < n; ++i) {
    float e = 0;
    for (int c = 0; c < 3; ++c) e += std::abs(render.data[3 * i + c] - ground_truth.data[3 * i + c]) / 3;
    const float t = std::clamp(e / full_scale, 0.f, 1.f) * 3;  // "hot": black, red, yellow, white
    out.data[3 * i] = std::min(t, 1.f);
    out.data[3 * i + 1] = std::clamp(t - 1, 0.f, 1.f);
    out.data[3 * i + 2] = std::clamp(t - 2, 0.f, 1.f);
  }
  return out;
}

namespace {

// ---------------------------------------------------------------------------------------------
// What the run holds.

struct RunFiles {
  std::vector<fs::path> pngs, jsons, logs, plys;
  std::vector<fs::path> datasets;  // folders holding a transforms.json
};

bool Inside(const fs::path& p, const fs::path& dir) {
  const auto [a, b] = std::mismatch(dir.begin(), dir.end(), p.begin(), p.end());
  return a == dir.end();
}

RunFiles ListRun(const std::string& run_dir) {
  RunFiles r;
  for (auto it = fs::recursive_directory_iterator(run_dir); it != fs::recursive_directory_iterator(); ++it) {
    const fs::path& p = it->path();
    if (p.filename().string().rfind('.', 0) == 0) {  // temp files and hidden folders
      if (it->is_directory()) it.disable_recursion_pending();
      continue;
    }
    if (it->is_directory()) {
      if (fs::exists(p / "transforms.json")) r.datasets.push_back(p);
      continue;
    }
    if (!it->is_regular_file()) continue;
    // A dataset's own images are inputs: shown only as the ground truth of renders.
    const bool in_dataset =
        std::any_of(r.datasets.begin(), r.datasets.end(), [&](const fs::path& d) { return Inside(p, d); });
    const std::string ext = LowerExtension(p.string());
    if (ext == ".png" && !in_dataset)
      r.pngs.push_back(p);
    else if (ext == ".json" && !in_dataset)
      r.jsons.push_back(p);
    else if (ext == ".jsonl")
      r.logs.push_back(p);
    else if (ext == ".ply")
      r.plys.push_back(p);
  }
  // Results first: files at the top of the run before those in sub-folders, then by name.
  auto by_depth = [](const fs::path& a, const fs::path& b) {
    const auto da = std::distance(a.begin(), a.end()), db = std::distance(b.begin(), b.end());
    return da != db ? da < db : a < b;
  };
  for (auto* v : {&r.pngs, &r.jsons, &r.logs, &r.plys, &r.datasets}) std::sort(v->begin(), v->end(), by_depth);
  return r;
}

std::string Fmt(double v, int digits = 3) {
  if (!std::isfinite(v)) return "-";
  std::ostringstream o;
  o.precision(digits);
  o << v;
  return o.str();
}

std::string ImageUri(const Image& im, const std::string& name) {
  // JPEG for photographs (renders, ground truth, heat-maps): a fifth of the PNG's size.
  return "data:image/jpeg;base64," + Base64Encode(EncodeImage(im, ".jpg", name, 88));
}

// ---------------------------------------------------------------------------------------------
// The 3D views: objects quantised to 16 bits per coordinate and base64-encoded.

struct ViewObject {
  std::string kind;  // "points" or "lines"
  std::string name;
  std::string colour;  // "#rrggbb"
  bool moved = false;  // drawn through the view's T (toggled by a checkbox)
  Eigen::Matrix3Xd xyz;
};

struct View3d {
  std::string id;
  std::string caption;
  std::vector<ViewObject> objects;
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();  // the moved objects' world_from_object
  bool has_t = false;
};

std::string EncodeObject(const ViewObject& o) {
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Ones();
  if (o.xyz.cols() > 0) {
    lo = o.xyz.rowwise().minCoeff();
    hi = o.xyz.rowwise().maxCoeff();
  }
  const Eigen::Vector3d span = (hi - lo).cwiseMax(1e-9);
  std::string bytes(static_cast<size_t>(o.xyz.cols()) * 6, '\0');
  for (Eigen::Index i = 0; i < o.xyz.cols(); ++i)
    for (int a = 0; a < 3; ++a) {
      const auto q = static_cast<std::uint16_t>(std::lround((o.xyz(a, i) - lo[a]) / span[a] * 65535.0));
      bytes[6 * i + 2 * a] = static_cast<char>(q & 0xff);
      bytes[6 * i + 2 * a + 1] = static_cast<char>(q >> 8);
    }
  std::ostringstream j;
  j.precision(9);
  j << "{\"kind\":\"" << o.kind << "\",\"name\":\"" << HtmlEscape(o.name) << "\",\"colour\":\"" << o.colour
    << "\",\"moved\":" << (o.moved ? "true" : "false") << ",\"n\":" << o.xyz.cols() << ",\"lo\":[" << lo[0] << ","
    << lo[1] << "," << lo[2] << "],\"hi\":[" << lo[0] + span[0] << "," << lo[1] + span[1] << "," << lo[2] + span[2]
    << "],\"data\":\"" << Base64Encode(bytes) << "\"}";
  return j.str();
}

std::string ViewHtml(const View3d& v) {
  // Framing: the bounding box of everything as drawn (moved objects through T).
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(INFINITY), hi = -lo;
  const Sim3d t = v.has_t ? Sim3d::FromMatrix(v.t, 1e-3) : Sim3d();
  for (const auto& o : v.objects)
    for (Eigen::Index i = 0; i < o.xyz.cols(); ++i) {
      const Eigen::Vector3d p =
          o.moved ? Eigen::Vector3d(t * Eigen::Vector3d(o.xyz.col(i))) : Eigen::Vector3d(o.xyz.col(i));
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
  if (!lo.allFinite()) lo = hi = Eigen::Vector3d::Zero();
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  const double radius = std::max(0.5 * (hi - lo).norm(), 1e-3);
  std::ostringstream h;
  h.precision(9);
  h << "<figure class=\"view3d\"><canvas id=\"" << v.id << "\" width=\"720\" height=\"480\"></canvas><figcaption>"
    << v.caption << " <span class=\"legend\">";
  for (const auto& o : v.objects)
    h << "<span style=\"color:" << o.colour << "\">&#9632; " << HtmlEscape(o.name) << "</span> ";
  h << "</span>";
  if (v.has_t) h << "<label><input type=\"checkbox\" id=\"" << v.id << "_t\" checked> apply T</label>";
  h << " <small>drag: rotate, wheel: zoom</small></figcaption></figure>";
  h << "<script>nerfregView(\"" << v.id << "\",{\"centre\":[" << centre[0] << "," << centre[1] << "," << centre[2]
    << "],\"radius\":" << radius << ",\"t\":[";
  for (int i = 0; i < 16; ++i) h << (i ? "," : "") << v.t.data()[i];  // column-major, as three.js wants
  h << "],\"objects\":[";
  for (size_t k = 0; k < v.objects.size(); ++k) h << (k ? "," : "") << EncodeObject(v.objects[k]);
  h << "]});</script>";
  return h.str();
}

// Draws the canvases with three.js: drag to orbit, wheel to zoom, no controls library needed.
// After the first frame the canvas records how many pixels differ from the background
// (data-drawn-pixels), so a headless browser can tell a drawn view from a blank one.
const char* kViewScript = R"JS(
function nerfregDecode(o) {
  var bin = atob(o.data), n = o.n * 3, out = new Float32Array(n);
  for (var i = 0; i < n; i++) {
    var q = bin.charCodeAt(2 * i) | (bin.charCodeAt(2 * i + 1) << 8), a = i % 3;
    out[i] = o.lo[a] + q / 65535 * (o.hi[a] - o.lo[a]);
  }
  return out;
}
function nerfregView(id, v) {
  var canvas = document.getElementById(id);
  var renderer;
  try {
    renderer = new THREE.WebGLRenderer({canvas: canvas, antialias: true, preserveDrawingBuffer: true});
  } catch (e) {
    canvas.insertAdjacentHTML('afterend', '<p>3D view unavailable: this browser has no WebGL.</p>');
    return;
  }
  var bg = 0x15181e;
  renderer.setClearColor(bg);
  var scene = new THREE.Scene(), moved = [], T = new THREE.Matrix4().fromArray(v.t);
  v.objects.forEach(function (o) {
    var g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(nerfregDecode(o), 3));
    var obj = o.kind == 'points'
        ? new THREE.Points(g, new THREE.PointsMaterial({color: o.colour, size: 2, sizeAttenuation: false}))
        : new THREE.LineSegments(g, new THREE.LineBasicMaterial({color: o.colour}));
    if (o.moved) { obj.matrixAutoUpdate = false; obj.matrix.copy(T); moved.push(obj); }
    scene.add(obj);
  });
  var c = new THREE.Vector3(v.centre[0], v.centre[1], v.centre[2]);
  var cam = new THREE.PerspectiveCamera(40, canvas.width / canvas.height, v.radius / 100, v.radius * 100);
  var yaw = 0.8, pitch = 0.5, dist = v.radius * 3.2;
  function draw() {
    cam.position.set(c.x + dist * Math.cos(pitch) * Math.sin(yaw), c.y + dist * Math.sin(pitch),
                     c.z + dist * Math.cos(pitch) * Math.cos(yaw));
    cam.lookAt(c);
    renderer.render(scene, cam);
  }
  var drag = null;
  canvas.addEventListener('mousedown', function (e) { drag = [e.clientX, e.clientY]; });
  window.addEventListener('mouseup', function () { drag = null; });
  window.addEventListener('mousemove', function (e) {
    if (!drag) return;
    yaw -= (e.clientX - drag[0]) * 0.01;
    pitch = Math.max(-1.5, Math.min(1.5, pitch + (e.clientY - drag[1]) * 0.01));
    drag = [e.clientX, e.clientY];
    draw();
  });
  canvas.addEventListener('wheel', function (e) {
    e.preventDefault();
    dist *= Math.exp(e.deltaY * 0.001);
    draw();
  }, {passive: false});
  var box = document.getElementById(id + '_t');
  if (box) box.addEventListener('change', function () {
    moved.forEach(function (o) { if (box.checked) o.matrix.copy(T); else o.matrix.identity(); });
    draw();
  });
  draw();
  var gl = renderer.getContext(), w = gl.drawingBufferWidth, h = gl.drawingBufferHeight;
  var px = new Uint8Array(w * h * 4), drawn = 0;
  gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, px);
  for (var i = 0; i < px.length; i += 4)
    if (px[i] != 0x15 || px[i + 1] != 0x18 || px[i + 2] != 0x1e) drawn++;
  canvas.setAttribute('data-drawn-pixels', drawn);
}
)JS";

// ---------------------------------------------------------------------------------------------
// Registrations.

struct Registration {
  fs::path path;
  Json t_json;
  Json errors;  // reg eval's output for it (null if none)
  fs::path before, after;
};

// reg eval --pair P --out E: E names no pair, so they are matched by name: errors_X.json goes
// with target_from_source_X.json (the demo's), or E with a "pair" field naming P.
bool ErrorsMatch(const fs::path& errors_path, const Json& errors, const fs::path& t_path) {
  if (errors.contains("pair") && errors["pair"].is_string()) {
    return fs::path(errors["pair"].get<std::string>()).filename() == t_path.filename();
  }
  auto suffix = [](std::string stem, const std::string& prefix) {
    return stem.rfind(prefix, 0) == 0 ? stem.substr(prefix.size()) : std::string("\x01");
  };
  const std::string a = suffix(errors_path.stem().string(), "errors");
  const std::string b = suffix(t_path.stem().string(), "target_from_source");
  return a == b || (a == "" && t_path.stem() == "T");
}

// The block's point cloud and dataset: block_0.ckpt -> block_0.ply (beside the checkpoint or in
// the run) and a dataset folder named block_0.
fs::path FindBlockFile(const std::vector<fs::path>& candidates, const std::string& checkpoint, bool by_folder) {
  const std::string stem = fs::path(checkpoint).stem().string();
  for (const auto& c : candidates) {
    if ((by_folder ? c.filename() : c.stem()).string() == stem) return c;
  }
  return {};
}

double SceneExtent(const Eigen::Matrix3Xd& pts) {
  if (pts.cols() == 0) return 1.0;
  return std::max((pts.rowwise().maxCoeff() - pts.rowwise().minCoeff()).norm(), 1e-3);
}

// ---------------------------------------------------------------------------------------------
// The page.

class PageBuilder {
 public:
  PageBuilder(const std::string& run_dir, const ReportOptions& options) : run_dir_(run_dir), options_(options) {
    files_ = ListRun(run_dir);
    for (const auto& p : files_.jsons) {
      try {
        jsons_[p] = ParseJson(ReadFileToString(p.string(), 4 << 20), p.string());
      } catch (const std::exception& e) {
        unreadable_[p] = e.what();
      }
    }
  }

  std::string Build() {
    FindRegistrations();
    const std::string registrations = RegistrationSection();
    const std::string renders = RenderSection();
    const std::string curves = CurveSection();
    const std::string cameras = CameraSection();
    const std::string tables = TableSection();
    const std::string images = ImageSection();
    const std::string title = options_.title.empty() ? fs::path(run_dir_).filename().string() : options_.title;
    std::ostringstream h;
    h << "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>" << HtmlEscape(title) << "</title><style>"
      << kStyle << "</style>";
    if (views_ > 0) h << "<script>" << ThreeJs() << "</script><script>" << kViewScript << "</script>";
    h << "</head><body><h1>" << HtmlEscape(title) << "</h1><p class=\"dim\">Run directory: <code>"
      << HtmlEscape(run_dir_) << "</code></p>";
    h << SummaryCard() << registrations << renders << curves << cameras << tables << images;
    // The time to the load event (scripts run, 3D views drawn), for bench/report_open.sh.
    h << "<script>addEventListener('load', function () { document.body.setAttribute('data-load-ms', "
      << "Math.round(performance.now())); });</script></body></html>\n";
    return h.str();
  }

 private:
  static constexpr const char* kStyle =
      "body{font-family:sans-serif;margin:1.5em auto;max-width:1500px;color:#222;padding:0 1em}"
      "h2{border-bottom:1px solid #ccc;margin-top:1.6em}.dim{color:#777}"
      "table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ddd;padding:2px 8px;text-align:left;"
      "font-size:13px}figure{display:inline-block;margin:4px;text-align:center;vertical-align:top}"
      "figcaption{font-size:12px}.pair img{width:min(720px,46vw)}.triple img{width:256px;image-rendering:pixelated}"
      ".card{display:flex;flex-wrap:wrap;gap:12px;margin:1em 0}.stat{border:1px solid #ddd;border-radius:8px;"
      "padding:10px 16px;min-width:150px;background:#fafafa}.stat b{display:block;font-size:24px}"
      ".stat span{font-size:12px;color:#666}.good{color:#1a7f37}.bad{color:#c62828}"
      "canvas{border-radius:6px;cursor:grab;max-width:100%}.legend span{margin-right:8px}"
      "details{margin:.4em 0}img.other{image-rendering:pixelated;max-width:320px}";

  std::string ThreeJs() const {
    if (!FileExists(options_.three_js)) {
      ThrowInputError(options_.three_js, "three.js",
                      "three.min.js for the report's 3D views (apt-get install libjs-three, or --three-js PATH)");
    }
    std::string js = ReadFileToString(options_.three_js, 16 << 20);
    // Inlined in a <script> element: a "</script" inside would end it.
    for (size_t p = js.find("</script"); p != std::string::npos; p = js.find("</script", p)) js.replace(p, 2, "<\\/");
    return js;
  }

  std::string Rel(const fs::path& p) const { return fs::relative(p, run_dir_).string(); }

  void Stat(const std::string& value, const std::string& label, const std::string& cls = "") {
    stats_ << "<div class=\"stat\"><b class=\"" << cls << "\">" << value << "</b><span>" << HtmlEscape(label)
           << "</span></div>";
  }

  std::string SummaryCard() const {
    const std::string s = stats_.str();
    return s.empty() ? "" : "<div class=\"card\">" + s + "</div>";
  }

  void FindRegistrations() {
    for (const auto& [p, j] : jsons_) {
      if (!j.is_object() || !j.contains("target_from_source")) continue;
      Registration r;
      r.path = p;
      r.t_json = j;
      for (const auto& [q, e] : jsons_) {
        if (e.is_object() && e.contains("rotation_error_deg") && ErrorsMatch(q, e, p)) {
          r.errors = e;
          used_.insert(q);
        }
      }
      const std::string stem = (p.parent_path() / p.stem()).string();
      if (FileExists(stem + "_before.png")) r.before = stem + "_before.png";
      if (FileExists(stem + "_after.png")) r.after = stem + "_after.png";
      used_.insert(r.before);
      used_.insert(r.after);
      used_.insert(p);
      registrations_.push_back(std::move(r));
    }
  }

  std::string Embed(const fs::path& png) const {
    return "data:image/png;base64," + Base64Encode(ReadFileToString(png.string(), options_.max_image_bytes));
  }

  std::string RegistrationSection() {
    if (registrations_.empty()) return "";
    std::ostringstream h;
    h << "<h2>Registration</h2>";
    for (const Registration& r : registrations_) {
      const JsonField t(r.t_json, r.path.string());
      const std::string name = Rel(r.path);
      const std::string method = r.t_json.value("method", std::string("?"));
      const double seconds = r.t_json.value("seconds", NAN), confidence = r.t_json.value("confidence", NAN);
      h << "<h3>" << HtmlEscape(name) << "</h3><p>method <b>" << HtmlEscape(method) << "</b>, confidence "
        << Fmt(confidence) << ", " << Fmt(seconds) << " s";
      if (!r.errors.is_null()) {
        const double rot = r.errors.value("rotation_error_deg", NAN);
        const double frac = r.errors.value("translation_error_fraction", NAN);
        h << "; against the ground truth: rotation error <b>" << Fmt(rot) << "&deg;</b>, translation error <b>"
          << Fmt(r.errors.value("translation_error", NAN)) << "</b> (" << Fmt(100 * frac) << " % of the extent)";
        const std::string cls = rot <= 5 && frac <= 0.05 ? "good" : "bad";
        Stat(Fmt(rot) + "&deg; / " + Fmt(100 * frac, 2) + " %", name + ": rotation / translation error", cls);
      }
      if (std::isfinite(seconds)) Stat(Fmt(seconds) + " s", name + ": registration time");
      h << "</p>";
      if (!r.before.empty() || !r.after.empty()) {
        h << "<div class=\"pair\">";
        if (!r.before.empty())
          h << "<figure><img alt=\"before\" src=\"" << Embed(r.before) << "\"><figcaption>before: source (orange) "
            << "in its own frame, target (blue)</figcaption></figure>";
        if (!r.after.empty())
          h << "<figure><img alt=\"after\" src=\"" << Embed(r.after) << "\"><figcaption>after: source mapped by "
            << "T</figcaption></figure>";
        h << "</div>";
      }
      h << BlocksView(r);
    }
    return h.str();
  }

  // Both blocks' points (and cameras) in the target's frame, the source's moved by T.
  std::string BlocksView(const Registration& r) {
    const std::string src_ckpt = r.t_json.value("source", std::string()),
                      tgt_ckpt = r.t_json.value("target", std::string());
    if (src_ckpt.empty() || tgt_ckpt.empty()) return "";
    const fs::path src_ply = FindBlockFile(files_.plys, src_ckpt, false),
                   tgt_ply = FindBlockFile(files_.plys, tgt_ckpt, false);
    if (src_ply.empty() || tgt_ply.empty()) {
      return "<p class=\"dim\">No 3D view: export the blocks' points beside the run (nerf export CKPT --points "
             "BLOCK.ply, named as the checkpoint).</p>";
    }
    View3d v;
    v.id = "view" + std::to_string(views_++);
    v.caption = "Registered blocks, target frame";
    v.t = JsonField(r.t_json, r.path.string())["target_from_source"].Matrix(4, 4);
    v.has_t = true;
    // Inputs registered in their capture's frame (reg register --source-dataparser): their files'
    // points moved there as registration moved them.
    const auto in_capture = [&](const char* key, Eigen::Matrix3Xd points) {
      if (!r.t_json.contains(key)) return points;
      const Sim3d capture_from_file =
          Sim3d::FromMatrix(JsonField(r.t_json, r.path.string())[key]["capture_from_file"].Matrix(4, 4), 1e-4);
      return capture_from_file.TransformPoints(points);
    };
    const Eigen::Matrix3Xd tgt =
        in_capture("target_frame", ReadPlyPoints(tgt_ply.string(), options_.max_points_per_block));
    const Eigen::Matrix3Xd src =
        in_capture("source_frame", ReadPlyPoints(src_ply.string(), options_.max_points_per_block));
    used_.insert(src_ply);
    used_.insert(tgt_ply);
    v.objects.push_back(
        {"points", "source " + fs::path(src_ckpt).stem().string() + " (T applied)", "#ff8c1a", true, src});
    v.objects.push_back({"points", "target " + fs::path(tgt_ckpt).stem().string(), "#3d8bff", false, tgt});
    const double depth = 0.06 * SceneExtent(tgt);
    for (const auto& [ckpt, colour, moved] :
         {std::tuple{src_ckpt, "#ffd199", true}, std::tuple{tgt_ckpt, "#a8ccff", false}}) {
      const fs::path d = FindBlockFile(files_.datasets, ckpt, true);
      if (d.empty()) continue;
      try {
        const Dataset ds = ReadTransformsJson((d / "transforms.json").string());
        v.objects.push_back({"lines", "cameras of " + fs::path(ckpt).stem().string(), colour, moved,
                             CameraFrustumSegments(ds, Sim3d(), depth)});
        drawn_datasets_.insert(d);
      } catch (const InputError&) {
        // A dataset we cannot read only loses its frusta here; its own section says why.
      }
    }
    return ViewHtml(v);
  }

  // Renders: a folder of PNGs named as a dataset's frames (nerf render --transforms). The dataset
  // whose folder name ends the render folder's name wins (renders_block_0 -> data/block_0), as
  // blocks share view names.
  std::string RenderSection() {
    std::map<fs::path, std::vector<fs::path>> by_dir;
    for (const auto& p : files_.pngs)
      if (!used_.count(p)) by_dir[p.parent_path()].push_back(p);
    std::ostringstream h;
    for (const auto& [dir, pngs] : by_dir) {
      const Dataset* match = nullptr;
      std::vector<const Frame*> frames;
      for (const auto& d : files_.datasets) {
        const Dataset* ds = LoadDataset(d);
        if (!ds) continue;
        std::vector<const Frame*> fr;
        for (const auto& p : pngs) {
          const auto it = std::find_if(ds->frames.begin(), ds->frames.end(), [&](const Frame& f) {
            return fs::path(f.name).replace_extension(".png") == p.filename();
          });
          fr.push_back(it == ds->frames.end() ? nullptr : &*it);
        }
        if (std::count(fr.begin(), fr.end(), nullptr) > 0) continue;
        const std::string dn = dir.filename().string(), sn = d.filename().string();
        const bool named = dn.size() >= sn.size() && dn.compare(dn.size() - sn.size(), sn.size(), sn) == 0;
        if (!match || named) {
          match = ds;
          frames = fr;
        }
        if (named) break;
      }
      if (!match) continue;
      h << RenderBlock(dir, pngs, *match, frames);
    }
    const std::string s = h.str();
    return s.empty() ? "" : "<h2>Renders and ground truth</h2>" + s;
  }

  const Dataset* LoadDataset(const fs::path& d) {
    auto it = datasets_.find(d);
    if (it == datasets_.end()) {
      std::unique_ptr<Dataset> ds;
      try {
        ds = std::make_unique<Dataset>(ReadTransformsJson((d / "transforms.json").string()));
      } catch (const InputError& e) {
        dataset_errors_[d] = e.what();
      }
      it = datasets_.emplace(d, std::move(ds)).first;
    }
    return it->second.get();
  }

  std::string RenderBlock(const fs::path& dir, const std::vector<fs::path>& pngs, const Dataset& ds,
                          const std::vector<const Frame*>& frames) {
    std::ostringstream rows, shown;
    double sum = 0;
    int n = 0;
    for (size_t k = 0; k < pngs.size(); ++k) {
      used_.insert(pngs[k]);
      Image render = ReadImage(pngs[k].string(), 0);
      if (render.channels == 4) render = CompositeOver(render, 1, 1, 1);
      Image gt = ReadImage(ds.ImagePath(*frames[k]), 0);
      if (gt.channels == 4) gt = CompositeOver(gt, 1, 1, 1);  // nerf render draws on white
      if (render.channels != 3 || gt.channels != 3 || gt.width != render.width || gt.height != render.height) continue;
      const double psnr = Psnr(render, gt);
      sum += psnr;
      ++n;
      rows << "<tr><td>" << HtmlEscape(pngs[k].filename().string()) << "</td><td>" << Fmt(psnr, 4) << "</td></tr>";
      if (static_cast<int>(k) >= options_.max_views) continue;
      const std::string name = pngs[k].filename().string();
      shown << "<div class=\"triple\"><figure><img alt=\"render\" src=\"" << ImageUri(render, name)
            << "\"><figcaption>render " << HtmlEscape(name)
            << "</figcaption></figure><figure><img alt=\"ground truth\" src=\"" << ImageUri(gt, name)
            << "\"><figcaption>ground truth</figcaption></figure><figure><img alt=\"error\" src=\""
            << ImageUri(ErrorHeatMap(render, gt), name) << "\"><figcaption>|error|, PSNR <b>" << Fmt(psnr, 4)
            << " dB</b></figcaption></figure></div>";
    }
    if (n == 0) return "";
    const double mean = sum / n;
    Stat(Fmt(mean, 4) + " dB", Rel(dir) + ": mean PSNR over " + std::to_string(n) + " views");
    std::ostringstream h;
    h << "<h3>" << HtmlEscape(Rel(dir)) << "</h3><p>Mean PSNR <b>" << Fmt(mean, 4) << " dB</b> over " << n
      << " views (ground truth composited on white). Error heat-map: black 0, red, yellow, white &ge; 0.25.</p>"
      << shown.str() << "<details><summary>PSNR of every view</summary><table><tr><th>view</th><th>PSNR (dB)</th></tr>"
      << rows.str() << "</table></details>";
    return h.str();
  }

  std::string CurveSection() {
    std::ostringstream h;
    for (const auto& p : files_.logs) {
      const auto curves = ReadCurves(p.string());
      const std::string name = Rel(p);
      std::ostringstream charts;
      for (const auto& c : curves) {
        if (c.x.size() < 2 || c.name == "seconds") continue;  // a single point is not a curve
        charts << SvgLineChart(name + ": " + c.name, {c}, ChartAxes{"step", c.name, PreferLogScale({c})});
      }
      // The log's last "seconds" is the training time.
      for (const auto& c : curves) {
        if (c.name == "seconds" && !c.y.empty()) Stat(Fmt(c.y.back()) + " s", name + ": training time");
        if (c.name == "test_psnr" && !c.y.empty()) Stat(Fmt(c.y.back(), 4) + " dB", name + ": final test PSNR");
      }
      if (!charts.str().empty()) h << "<h3>" << HtmlEscape(name) << "</h3>" << charts.str();
    }
    const std::string s = h.str();
    return s.empty() ? "" : "<h2>Training curves</h2>" + s;
  }

  // Posed image sets not drawn with a registration (dbarf poses' output, input datasets).
  std::string CameraSection() {
    std::ostringstream h;
    int shown = 0;
    for (const auto& d : files_.datasets) {
      if (drawn_datasets_.count(d)) continue;
      const Dataset* ds = LoadDataset(d);
      if (!ds) {
        h << "<p>" << HtmlEscape(Rel(d)) << ": unreadable: " << HtmlEscape(dataset_errors_[d]) << "</p>";
        continue;
      }
      if (shown >= options_.max_camera_views) {
        h << "<p>" << HtmlEscape(Rel(d)) << ": " << ds->frames.size() << " cameras (not drawn)</p>";
        continue;
      }
      ++shown;
      Eigen::Matrix3Xd centres(3, ds->frames.size());
      for (size_t k = 0; k < ds->frames.size(); ++k)
        centres.col(k) = ds->frames[k].cam_from_world.Inverse().translation;
      View3d v;
      v.id = "view" + std::to_string(views_++);
      v.caption = HtmlEscape(Rel(d / "transforms.json")) + ": " + std::to_string(ds->frames.size()) + " cameras";
      v.objects.push_back(
          {"lines", "cameras", "#ffd166", false, CameraFrustumSegments(*ds, Sim3d(), 0.08 * SceneExtent(centres))});
      v.objects.push_back({"points", "camera centres", "#ffffff", false, centres});
      h << ViewHtml(v);
    }
    const std::string s = h.str();
    return s.empty() ? "" : "<h2>Posed images</h2>" + s;
  }

  std::string TableSection() {
    std::ostringstream h;
    for (const auto& p : files_.jsons) {
      const std::string rel = Rel(p);
      h << "<details" << (used_.count(p) ? "" : " open") << "><summary>" << HtmlEscape(rel) << "</summary>";
      if (unreadable_.count(p))
        h << "<p>unreadable: " << HtmlEscape(unreadable_[p]) << "</p>";
      else
        h << JsonTable(jsons_[p]);
      h << "</details>";
    }
    const std::string s = h.str();
    return s.empty() ? "" : "<h2>Metrics and options</h2>" + s;
  }

  static std::string JsonTable(const Json& j) {
    std::ostringstream o;
    o << "<table>";
    if (j.is_object()) {
      for (auto it = j.begin(); it != j.end(); ++it) {
        const std::string v = it.value().is_string() ? it.value().get<std::string>() : it.value().dump();
        o << "<tr><th>" << HtmlEscape(it.key()) << "</th><td>"
          << HtmlEscape(v.size() > 400 ? v.substr(0, 400) + " ..." : v) << "</td></tr>";
      }
    } else {
      const std::string v = j.dump();
      o << "<tr><td>" << HtmlEscape(v.size() > 2000 ? v.substr(0, 2000) + " ..." : v) << "</td></tr>";
    }
    o << "</table>";
    return o.str();
  }

  std::string ImageSection() {
    std::ostringstream h;
    std::string current_dir = "\x01";
    int embedded = 0;
    for (const auto& p : files_.pngs) {
      if (used_.count(p)) continue;
      const std::string rel = Rel(p);
      const std::string dir = fs::path(rel).parent_path().string();
      if (dir != current_dir) {
        current_dir = dir;
        h << "<h3>" << HtmlEscape(dir.empty() ? "." : dir) << "</h3>";
      }
      const auto size = static_cast<long long>(fs::file_size(p));
      if (embedded >= options_.max_images || size > options_.max_image_bytes) {
        h << "<p>" << HtmlEscape(rel) << " (not embedded)</p>";
        continue;
      }
      ++embedded;
      h << "<figure><img class=\"other\" alt=\"" << HtmlEscape(rel) << "\" src=\"" << Embed(p) << "\"><figcaption>"
        << HtmlEscape(p.filename().string()) << "</figcaption></figure>";
    }
    const std::string s = h.str();
    return s.empty() ? "" : "<h2>Other images</h2>" + s;
  }

  std::string run_dir_;
  ReportOptions options_;
  RunFiles files_;
  std::map<fs::path, Json> jsons_;
  std::map<fs::path, std::string> unreadable_;
  std::vector<Registration> registrations_;
  std::set<fs::path> used_;  // files shown in a dedicated section
  std::set<fs::path> drawn_datasets_;
  std::map<fs::path, std::unique_ptr<Dataset>> datasets_;  // null: unreadable
  std::map<fs::path, std::string> dataset_errors_;
  std::ostringstream stats_;
  int views_ = 0;
};

}  // namespace

void WriteRunReport(const std::string& run_dir, const std::string& out_path, const ReportOptions& options) {
  options.Check();
  if (!DirExists(run_dir)) ThrowInputError(run_dir, "", "a run directory");
  PageBuilder page(run_dir, options);
  WriteFileAtomic(out_path, page.Build());
}

}  // namespace nerfreg
