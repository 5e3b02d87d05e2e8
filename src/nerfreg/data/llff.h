#pragma once
// LLFF scenes: `poses_bounds.npy` (N x 17 float64: a 3x5 [R | t | (h, w, f)] camera-to-world
// matrix whose rotation columns are (down, right, backwards), then near and far depth bounds)
// beside an `images/` folder whose sorted file names give the frame order.
#include <string>

#include "nerfreg/data/dataset.h"

namespace nerfreg {

struct LlffOptions {
  std::string image_dir = "images";  // or images_4, images_8 (downsampled): focal is rescaled
  int test_every = 8;                // every k-th image is a test view (LLFF convention); 0: none
  void Check() const;
};

// Throws InputError naming poses_bounds.npy or the image folder on any mismatch.
Dataset ReadLlff(const std::string& scene_dir, const LlffOptions& options = LlffOptions{});

// Writes scene_dir/poses_bounds.npy for the frames in the order of their sorted names (the order
// LLFF readers assume). Frames without near/far get the given defaults. Images are not copied.
void WriteLlffPoses(const Dataset& dataset, const std::string& scene_dir, double default_near = 0.1,
                    double default_far = 100.0);

}  // namespace nerfreg
