#pragma once
// `dbarf render`'s job: novel views with the generalizable NeRF from posed images (the output of
// dbarf poses, dbarf_data/posed_images.h): one PNG per camera of a camera file, named as its frame, and
// its inverse depth in OUT/depth/, all moved into place at once.
#include <c10/core/Device.h>

#include <string>

#include "nerfreg/dbarf_data/dbarf_scene.h"

namespace nerfreg {

struct DbarfRenderJob {
  std::string posed;                      // posed images (or any posed dataset: its cameras are estimated again)
  DbarfCameraEstimator estimate_cameras;  // how (empty: posed images only)
  std::string transforms;          // cameras to render (transforms.json, LLFF or COLMAP), in the posed images' frame
  std::string out;                 // output folder
  std::string weights;             // DBARF weights
  int num_sources = 8;             // source views per rendered view (nearest cameras)
  c10::Device device = c10::kCPU;  // where the networks run (`--device`); images are written from the CPU
  bool force = false;              // replace an existing output
  void Check() const;              // throws InputError naming the flag
};

// Returns the number of views rendered. Throws InputError on bad input; writes nothing then.
int RenderDbarfViews(const DbarfRenderJob& job);

}  // namespace nerfreg
