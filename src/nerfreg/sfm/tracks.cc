#include "nerfreg/sfm/tracks.h"

#include <algorithm>
#include <iterator>
#include <numeric>
#include <stdexcept>
#include <unordered_map>

namespace nerfreg {

void TrackOptions::Check() const {
  if (min_length < 2) throw std::invalid_argument("TrackOptions: min_length < 2");
}

namespace {

int Find(std::vector<int>& parent, int x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];
    x = parent[x];
  }
  return x;
}

}  // namespace

std::vector<Track> BuildTracks(const ViewGraph& graph, const std::vector<bool>& usable, const TrackOptions& options) {
  options.Check();
  if (!usable.empty() && usable.size() != graph.edges.size())
    throw std::invalid_argument("BuildTracks: usable has the wrong size");
  const int n = static_cast<int>(graph.keypoints.size());
  std::vector<int> offset(n + 1, 0);  // keypoint (image, k) -> node offset[image] + k
  for (int i = 0; i < n; ++i) offset[i + 1] = offset[i] + static_cast<int>(graph.keypoints[i].size());
  std::vector<int> parent(offset[n]);
  std::iota(parent.begin(), parent.end(), 0);
  std::vector<std::vector<int>> images_of(offset[n]);  // per root: its images, sorted
  for (int i = 0; i < n; ++i)
    for (int node = offset[i]; node < offset[i + 1]; ++node) images_of[node] = {i};
  // Strongest edges first: when two matches conflict, the one from the better edge stays.
  std::vector<int> order;
  for (size_t e = 0; e < graph.edges.size(); ++e)
    if (usable.empty() || usable[e]) order.push_back(static_cast<int>(e));
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return graph.edges[a].num_inliers > graph.edges[b].num_inliers; });
  for (int e : order) {
    const ViewGraphEdge& edge = graph.edges[e];
    if (edge.i < 0 || edge.j < 0 || edge.i >= n || edge.j >= n)
      throw std::invalid_argument("BuildTracks: edge names an image without keypoints");
    for (const auto& [ki, kj] : edge.inlier_matches) {
      if (ki < 0 || kj < 0 || ki >= offset[edge.i + 1] - offset[edge.i] || kj >= offset[edge.j + 1] - offset[edge.j]) {
        throw std::invalid_argument("BuildTracks: match indexes a missing keypoint");
      }
      int a = Find(parent, offset[edge.i] + ki), b = Find(parent, offset[edge.j] + kj);
      if (a == b) continue;
      std::vector<int>& ia = images_of[a];
      std::vector<int>& ib = images_of[b];
      std::vector<int> merged;
      std::set_union(ia.begin(), ia.end(), ib.begin(), ib.end(), std::back_inserter(merged));
      if (merged.size() != ia.size() + ib.size()) continue;  // two keypoints of one image: refused
      if (ia.size() < ib.size()) std::swap(a, b);
      parent[b] = a;
      images_of[a] = std::move(merged);
      images_of[b].clear();
    }
  }
  std::unordered_map<int, int> track_of_root;
  std::vector<Track> tracks;
  for (int i = 0; i < n; ++i) {
    for (int k = 0; k < offset[i + 1] - offset[i]; ++k) {
      const int root = Find(parent, offset[i] + k);
      if (images_of[root].size() < static_cast<size_t>(options.min_length)) continue;
      auto [it, inserted] = track_of_root.emplace(root, static_cast<int>(tracks.size()));
      if (inserted) tracks.emplace_back();
      tracks[it->second].elements.push_back({i, k});
    }
  }
  return tracks;
}

}  // namespace nerfreg
