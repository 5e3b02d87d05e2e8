#pragma once
// Tracks: the keypoints of several images that see one scene point, chained from the view graph's
// pairwise inlier correspondences by union-find (as COLMAP's and Theia's track builders do).
// A match that would join two different keypoints of one image into a track is refused (a wrong
// match somewhere along the chain); edges are merged strongest first (most inliers), so the
// refused matches are those of weaker edges. Every track therefore has at most one keypoint per
// image; wrong matches that remain are for triangulation to reject.
#include <vector>

#include "nerfreg/viewgraph/view_graph.h"

namespace nerfreg {

// One keypoint of one image: ViewGraph::keypoints[image][keypoint].
struct TrackElement {
  int image = 0;
  int keypoint = 0;
};

struct Track {
  std::vector<TrackElement> elements;  // sorted by image, at most one per image
};

struct TrackOptions {
  int min_length = 2;  // tracks seen by fewer images are dropped
  void Check() const;  // throws std::invalid_argument
};

// Builds tracks from the inlier_matches of the edges with usable[e] (one flag per graph edge, or
// empty for all), so edges rejected by rotation averaging do not glue tracks together.
// Throws std::invalid_argument when a match indexes a keypoint that graph.keypoints lacks.
std::vector<Track> BuildTracks(const ViewGraph& graph, const std::vector<bool>& usable, const TrackOptions& options);

}  // namespace nerfreg
