#pragma once
// Sweet Home 3D furniture (render/sh3f.h: Debian's sweethome3d-furniture, 820 textured artist
// meshes) as the registration network's objects, split by mesh into train / validation / test once,
// in a committed file (models/sh3f_split.json), so held-out meshes stay held out whatever is trained.
//
// A model's split comes from a salted FNV-1a 64 hash of a key, mod 100: < train_percent train, then
// val_percent val, the rest test. The key is the model's id, except that models whose OBJ entries
// are byte-identical (same CRC-32 and size) take the smallest id among them, so copies of one mesh
// never straddle splits. Models that do not load, or are degenerate for registration (too few
// triangles, flat), are listed under "excluded" with the reason and in no split.
//
// The file: {"format": "nerfreg-sh3f-split", "version": 1, "salt", "train_percent",
// "val_percent", "furniture_dir", "counts": {...}, "train" / "val" / "test": [ids, by hash],
// "excluded": {id: reason}, "models": {id: {"archive", "category", "triangles", "textures",
// "warnings"}}}. The split lists are in hash order, so their first N are a stable random sample.
#include <string>
#include <vector>

#include "nerfreg/render/sh3f.h"
#include "nerfreg/util/json_util.h"

namespace nerfreg {

struct Sh3fSplitOptions {
  std::string furniture_dir = kSh3fFurnitureDir;  // the .sh3f archives
  int train_percent = 80;                         // of the hash range
  int val_percent = 10;                           // the rest (10) is test
  std::string salt = "nerfreg-sh3f-split-v1";     // another salt gives another split
  int min_triangles = 12;                         // fewer: degenerate
  int max_triangles = 1000000;                    // more: too slow to render 120 views (excluded)
  // Smallest over largest side of the bounding box (the catalog's size) below this: flat (a rug, a
  // picture, a door leaf), a plane whose registration is ambiguous.
  double min_thickness = 0.02;
  void Check() const;  // throws InputError naming the option
};

// "train", "val" or "test" for a split key (see above).
std::string Sh3fSplitOf(const std::string& key, const Sh3fSplitOptions& options);

// Loads every model of options.furniture_dir and returns the split file's JSON (see above).
Json MakeSh3fSplit(const Sh3fSplitOptions& options);

// The models of one split ("train", "val" or "test") of a split file, in its (hash) order, looked up
// in the catalogs of `furniture_dir`. Throws InputError naming the file on a missing or malformed
// file or split, and naming an id the catalogs lack (another package version).
std::vector<Sh3fModel> ReadSh3fSplit(const std::string& split_file, const std::string& split,
                                     const std::string& furniture_dir = kSh3fFurnitureDir);

}  // namespace nerfreg
