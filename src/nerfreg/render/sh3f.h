#pragma once
// Sweet Home 3D furniture libraries (.sh3f): zip archives of OBJ + MTL + textures with a catalog,
// PluginFurnitureCatalog.properties (Java properties: "id#N=...", "model#N=/folder/x.obj",
// "width#N" / "depth#N" / "height#N" in cm, optional "modelRotation#N" = 9 numbers). Debian's
// sweethome3d-furniture ships 5 of them (/usr/share/sweethome3d/furniture, 820 models: real,
// textured artist meshes). Everything is read from the archive in memory (util/zip_reader.h: entry
// names that climb out of the archive, zip bombs and corrupt entries are refused by name).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "nerfreg/render/mesh.h"
#include "nerfreg/render/obj_reader.h"
#include "nerfreg/util/zip_reader.h"

namespace nerfreg {

// Where Debian's sweethome3d-furniture puts its archives.
constexpr const char* kSh3fFurnitureDir = "/usr/share/sweethome3d/furniture";

// One model of a catalog.
struct Sh3fModel {
  std::string id;        // the catalog's id, e.g. "Kator Legaz#screen-door" (unique across archives)
  std::string name;      // display name (UTF-8)
  std::string category;  // e.g. "Bathroom"
  std::string archive;   // path of the .sh3f file
  std::string model;     // the OBJ's entry in the archive, e.g. "katorlegaz/screen-door/screen-door.obj"
  Eigen::Vector3f size_cm = Eigen::Vector3f::Zero();             // width (x), height (y), depth (z), cm
  Eigen::Matrix3f model_rotation = Eigen::Matrix3f::Identity();  // turns the OBJ upright (y up)
};

// The models of one archive's PluginFurnitureCatalog.properties, in catalog order. Throws
// InputError naming the archive on a missing or unreadable catalog; a model without an id or a
// model path, or whose OBJ is not in the archive, is left out with a warning in `warnings`.
std::vector<Sh3fModel> ReadSh3fCatalog(const ZipReader& archive, std::vector<std::string>* warnings = nullptr);

// Every *.sh3f in `dir`, archives in name order. Throws InputError when `dir` holds none, or two
// models share an id.
std::vector<Sh3fModel> ReadSh3fCatalogs(const std::string& dir = kSh3fFurnitureDir,
                                        std::vector<std::string>* warnings = nullptr);

// The model's OBJ with its materials and textures (render/obj_reader.h), as Sweet Home 3D shows
// it: turned by model_rotation, then scaled per axis to the catalog's size (cm; an axis of size 0
// is scaled by the mean of the others). Throws InputError naming archive and entry.
TriangleMesh LoadSh3fModel(const ZipReader& archive, const Sh3fModel& model,
                           const ObjReadOptions& options = ObjReadOptions(), ObjReadReport* report = nullptr);
// The same, opening model.archive.
TriangleMesh LoadSh3fModel(const Sh3fModel& model, const ObjReadOptions& options = ObjReadOptions(),
                           ObjReadReport* report = nullptr);

// Java .properties text (ISO-8859-1, \uXXXX escapes, '\\' line continuations) as key -> value,
// values in UTF-8. Never throws; malformed escapes are kept as written.
std::vector<std::pair<std::string, std::string>> ParseJavaProperties(const std::string& text);

}  // namespace nerfreg
