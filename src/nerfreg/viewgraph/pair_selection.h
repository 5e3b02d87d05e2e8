#pragma once
// Which image pairs to match. Matching and verifying every pair costs N (N - 1) / 2 pair stages:
// 19 900 at 200 photos, 124 750 at 500. Captures of 50-500 photos need far fewer: a frame of a
// video overlaps its next few frames; a photo of an unordered set overlaps the few photos that
// look most like it. As COLMAP's exhaustive, sequential and vocabulary-tree matchers, this module
// chooses the pairs to match from names and SIFT descriptors alone, before any matching:
//
//  exhaustive  every pair (i, j), i < j.
//  sequential  images in natural name order ("f2" before "f10"); each with the next `overlap`
//              ones (or, with quadratic_overlap, also the ones 2^k places on, k < overlap), and,
//              for loop closure, every loop_detection_period-th image with its
//              retrieval_neighbors most similar images (the retrieval below).
//  retrieval   each image with its retrieval_neighbors most similar images, the union made
//              symmetric. Similarity: cosine of tf-idf bag-of-words vectors over a visual vocabulary
//              learnt from the set's own descriptors (a hierarchical k-means tree, as Nister and
//              Stewenius 2006; nothing downloaded).
//  auto        exhaustive up to exhaustive_max_images images, else retrieval, joined by the
//              sequential pairs (without loop detection) when the names look like numbered frames
//              (NamesLookNumbered).
//
// Cost of retrieval (N images, m descriptors kept per image, b branching, d depth, s sample, I
// k-means iterations): vocabulary s * b * d * I * 128 multiply-adds, quantisation N * m * b * d * 128,
// scoring sum over words of (images holding the word)^2 <= N^2 * m, top-k N^2 log k. All but the last
// grow linearly in N; the last is N^2 additions, negligible below thousands of images.
// Measured timings: bench/pair_selection_bench.cc.
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace nerfreg {

// One image's SIFT descriptors, one 128-byte row per keypoint: plain SIFT as OpenCV computes it
// (its float values are integers 0..255, so the cast to uint8 is exact), or RootSIFT rescaled to
// 0..255 (as COLMAP stores it). Retrieval works on either; the rows need not be in any order.
using SiftDescriptors = Eigen::Matrix<uint8_t, Eigen::Dynamic, 128, Eigen::RowMajor>;

enum class PairStrategy { kExhaustive, kSequential, kRetrieval, kAuto };

// "exhaustive", "sequential", "retrieval" or "auto" (the values of --pairs); anything else throws
// InputError naming --pairs.
PairStrategy ParsePairStrategy(const std::string& name);
std::string PairStrategyName(PairStrategy strategy);

struct PairSelectionOptions {
  PairStrategy strategy = PairStrategy::kAuto;
  // Sequential: each image is paired with the next `overlap` images in name order (--overlap).
  int overlap = 10;
  // Sequential: also pair each image with the images 2^k places on, k = 0 .. overlap - 1 (COLMAP's
  // quadratic overlap: wider baselines at a cost of overlap pairs per image).
  bool quadratic_overlap = false;
  // Sequential: every loop_detection_period-th image in name order is also paired with its
  // retrieval_neighbors most similar images, so that a capture that returns to where it began
  // (an orbit) closes its loop. 0: no loop detection (and no descriptors are read).
  int loop_detection_period = 10;
  // Retrieval (and loop detection): the most similar images each image is paired with.
  int retrieval_neighbors = 25;
  // Auto: every pair up to this many images; beyond, retrieval (+ sequential for numbered frames).
  int exhaustive_max_images = 50;

  // The vocabulary tree: `vocabulary_branching` children per node, `vocabulary_depth` levels, so at
  // most branching^depth words (4096 by default; fewer when the sample is small).
  int vocabulary_branching = 16;
  int vocabulary_depth = 3;
  // Descriptors the vocabulary is learnt from, taken evenly from every image.
  int vocabulary_sample = 40000;
  int kmeans_iterations = 8;  // Lloyd iterations per tree node
  // Descriptors per image that are quantised into words (evenly strided through the rows):
  // retrieval's cost is linear in it, and a thousand or two describe a view well enough.
  int max_descriptors_per_image = 2000;
  unsigned seed = 1;  // k-means seeding (the pairs are deterministic for a given seed)

  void Check() const;  // throws InputError naming the option (command-line names where there are)
};

// The pairs (i, j) to match, i < j, indices into descriptors / names, unique, sorted. descriptors
// and names have one entry per image (descriptors are read by retrieval and loop detection only;
// an image without descriptors gets no retrieval pairs). Deterministic: the same input and options
// give the same pairs, whatever the thread count. Throws std::invalid_argument when the sizes
// differ; calls options.Check().
std::vector<std::pair<int, int>> SelectPairs(const std::vector<SiftDescriptors>& descriptors,
                                             const std::vector<std::string>& names,
                                             const PairSelectionOptions& options);

// --- The parts, for callers that want them alone and for tests. ---

// Image indices in natural name order: digit runs compare as numbers ("f2" < "f10"), ties by index.
std::vector<int> NaturalNameOrder(const std::vector<std::string>& names);

// True when every name holds a digit run and all names are equal once their last digit run is
// removed ("frame_0001.png", "frame_0002.png", ...): frames of one video or one burst of photos.
bool NamesLookNumbered(const std::vector<std::string>& names);

// The sequential pairs (overlap / quadratic_overlap of options) over natural name order, without
// loop detection.
std::vector<std::pair<int, int>> SequentialPairs(const std::vector<std::string>& names,
                                                 const PairSelectionOptions& options);

// The N x N retrieval similarity: cosine of the images' tf-idf bag-of-words vectors over a
// vocabulary learnt from these descriptors (the vocabulary options of options). In [0, 1],
// symmetric; the diagonal is 1 for an image with words, 0 for one without.
Eigen::MatrixXf RetrievalSimilarity(const std::vector<SiftDescriptors>& descriptors,
                                    const PairSelectionOptions& options);

// Each of `images` (indices) with its k most similar other images (similarity > 0; ties by
// index), as pairs i < j, unique, sorted.
std::vector<std::pair<int, int>> NearestPairs(const Eigen::MatrixXf& similarity, const std::vector<int>& images, int k);

}  // namespace nerfreg
