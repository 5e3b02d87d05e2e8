#include "nerfreg/viewgraph/pair_selection.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <opencv2/core.hpp>
#include <random>
#include <stdexcept>

#include "nerfreg/util/error.h"
#include "nerfreg/util/logging.h"
#include "nerfreg/viewgraph/descriptor_product.h"

namespace nerfreg {
namespace {

using DescriptorsF = Eigen::Matrix<float, Eigen::Dynamic, 128, Eigen::RowMajor>;
using Pairs = std::vector<std::pair<int, int>>;

// Per row r of x, the index of the nearest row of centers (the first on ties):
// argmin_c |c|^2 - 2 x_r.c, the products x centers^T by the BLAS. Eigen's own product ran with
// SSE2 only (the build targets baseline x86-64) and was a fifth of `dbarf poses` on 96
// forward-facing views (perf); OpenBLAS picks the CPU's widest vectors.
std::vector<int> NearestCenters(const DescriptorsF& x, const DescriptorsF& centers,
                                const Eigen::VectorXf& center_norms) {
  const int n = static_cast<int>(x.rows()), k = static_cast<int>(centers.rows());
  std::vector<int> nearest(n, 0);
  if (n == 0 || k == 0) return nearest;
  // dot[r * k + c] = centers_c . x_r: row r holds x_r's products with every centre.
  std::vector<float> dot(static_cast<size_t>(n) * k);
  DotProducts128(centers.data(), k, x.data(), n, dot.data());
  for (int r = 0; r < n; ++r) {
    const float* row = dot.data() + static_cast<size_t>(r) * k;
    float best = center_norms[0] - 2 * row[0];
    for (int c = 1; c < k; ++c) {
      const float d = center_norms[c] - 2 * row[c];
      if (d < best) best = d, nearest[r] = c;
    }
  }
  return nearest;
}

void SortUnique(Pairs* pairs) {
  for (auto& p : *pairs)
    if (p.first > p.second) std::swap(p.first, p.second);
  std::sort(pairs->begin(), pairs->end());
  pairs->erase(std::unique(pairs->begin(), pairs->end()), pairs->end());
}

// -1, 0, 1 as a compares with b, digit runs as numbers (leading zeros ignored).
int NaturalCompare(const std::string& a, const std::string& b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])), db = std::isdigit(static_cast<unsigned char>(b[j]));
    if (da && db) {
      size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      size_t is = i, js = j;
      while (is + 1 < ie && a[is] == '0') ++is;
      while (js + 1 < je && b[js] == '0') ++js;
      if (ie - is != je - js) return ie - is < je - js ? -1 : 1;
      const int c = a.compare(is, ie - is, b, js, je - js);
      if (c != 0) return c < 0 ? -1 : 1;
      i = ie, j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j] ? -1 : 1;
      ++i, ++j;
    }
  }
  if (i < a.size() || j < b.size()) return i < a.size() ? 1 : -1;
  return a < b ? -1 : (b < a ? 1 : 0);  // "f01" and "f1": plain order decides
}

// A hierarchical k-means tree over 128-d descriptors; leaves are words.
class VocabularyTree {
 public:
  VocabularyTree(const DescriptorsF& sample, const PairSelectionOptions& options);
  int num_words() const { return num_words_; }
  // The word of every row of d: per tree node, one matrix product of the rows that reach it.
  std::vector<int> Quantize(const DescriptorsF& d) const;

 private:
  struct Node {
    DescriptorsF centers;          // k x 128
    Eigen::VectorXf center_norms;  // squared
    std::vector<int> child;        // >= 0: a node; < 0: the word -child - 1
  };
  std::vector<Node> nodes_;
  int num_words_ = 0;
};

// Lloyd's k-means (k-means++ seeding) of the rows `rows` of x: the centres, and each row's label.
DescriptorsF KMeans(const DescriptorsF& x, int k, int iterations, std::mt19937* rng, std::vector<int>* labels) {
  const int n = static_cast<int>(x.rows());
  DescriptorsF centers(k, 128);
  Eigen::VectorXf nearest = Eigen::VectorXf::Constant(n, std::numeric_limits<float>::max());
  int pick = std::uniform_int_distribution<int>(0, n - 1)(*rng);
  for (int c = 0; c < k; ++c) {
    centers.row(c) = x.row(pick);
    nearest = nearest.cwiseMin((x.rowwise() - centers.row(c)).rowwise().squaredNorm());
    const double total = nearest.cast<double>().sum();
    if (!(total > 0)) {  // fewer distinct rows than k: the remaining centres repeat
      for (int r = c + 1; r < k; ++r) centers.row(r) = centers.row(c);
      break;
    }
    double u = std::uniform_real_distribution<double>(0, total)(*rng);
    pick = n - 1;
    for (int r = 0; r < n; ++r)
      if ((u -= nearest[r]) <= 0) {
        pick = r;
        break;
      }
  }
  labels->assign(n, 0);
  for (int it = 0; it <= iterations; ++it) {
    const std::vector<int> nearest = NearestCenters(x, centers, centers.rowwise().squaredNorm());
    const bool changed = nearest != *labels;
    *labels = nearest;
    if (it == iterations || (!changed && it > 0)) break;
    DescriptorsF sum = DescriptorsF::Zero(k, 128);
    Eigen::VectorXi count = Eigen::VectorXi::Zero(k);
    for (int r = 0; r < n; ++r) {
      sum.row((*labels)[r]) += x.row(r);
      ++count[(*labels)[r]];
    }
    for (int c = 0; c < k; ++c)
      if (count[c] > 0) centers.row(c) = sum.row(c) / static_cast<float>(count[c]);  // else kept
  }
  return centers;
}

VocabularyTree::VocabularyTree(const DescriptorsF& sample, const PairSelectionOptions& options) {
  struct Task {
    int node;
    int level;
    std::vector<int> rows;
  };
  std::vector<Task> queue;
  std::vector<int> all(sample.rows());
  for (int r = 0; r < sample.rows(); ++r) all[r] = r;
  nodes_.emplace_back();
  queue.push_back({0, 0, std::move(all)});
  // Breadth first; each node's seed is its index, so the tree does not depend on visiting order.
  for (size_t q = 0; q < queue.size(); ++q) {
    const Task task = std::move(queue[q]);
    DescriptorsF x(task.rows.size(), 128);
    for (size_t r = 0; r < task.rows.size(); ++r) x.row(r) = sample.row(task.rows[r]);
    const int k = std::min<int>(options.vocabulary_branching, x.rows());
    std::mt19937 rng(options.seed * 2654435761u + static_cast<unsigned>(task.node));
    std::vector<int> labels;
    DescriptorsF centers = KMeans(x, k, options.kmeans_iterations, &rng, &labels);
    std::vector<std::vector<int>> members(k);
    for (size_t r = 0; r < labels.size(); ++r) members[labels[r]].push_back(task.rows[r]);
    nodes_[task.node].centers = centers;
    nodes_[task.node].center_norms = centers.rowwise().squaredNorm();
    nodes_[task.node].child.assign(k, 0);
    for (int c = 0; c < k; ++c) {
      // A child too small to split into `branching` clusters of a few rows each is a word.
      if (task.level + 1 >= options.vocabulary_depth ||
          static_cast<int>(members[c].size()) < 2 * options.vocabulary_branching) {
        nodes_[task.node].child[c] = -(num_words_++) - 1;
      } else {
        nodes_[task.node].child[c] = static_cast<int>(nodes_.size());
        nodes_.emplace_back();
        queue.push_back({nodes_[task.node].child[c], task.level + 1, std::move(members[c])});
      }
    }
  }
}

std::vector<int> VocabularyTree::Quantize(const DescriptorsF& d) const {
  std::vector<int> words(d.rows(), 0);
  std::vector<std::pair<int, std::vector<int>>> work(1, {0, std::vector<int>(d.rows())});
  for (int r = 0; r < d.rows(); ++r) work[0].second[r] = r;
  while (!work.empty()) {
    const auto [node_id, rows] = std::move(work.back());
    work.pop_back();
    if (rows.empty()) continue;
    const Node& node = nodes_[node_id];
    DescriptorsF x(rows.size(), 128);
    for (size_t r = 0; r < rows.size(); ++r) x.row(r) = d.row(rows[r]);
    const std::vector<int> nearest = NearestCenters(x, node.centers, node.center_norms);
    std::vector<std::vector<int>> to_child(node.child.size());
    for (size_t r = 0; r < rows.size(); ++r) {
      const int best = nearest[r];
      if (node.child[best] < 0)
        words[rows[r]] = -node.child[best] - 1;
      else
        to_child[best].push_back(rows[r]);
    }
    for (size_t c = 0; c < to_child.size(); ++c)
      if (!to_child[c].empty()) work.push_back({node.child[c], std::move(to_child[c])});
  }
  return words;
}

// At most `limit` rows of d, evenly strided, as floats.
DescriptorsF Strided(const SiftDescriptors& d, int limit) {
  const int n = static_cast<int>(d.rows());
  const int m = std::min(n, limit);
  DescriptorsF out(m, 128);
  for (int r = 0; r < m; ++r) out.row(r) = d.row(static_cast<int>(static_cast<int64_t>(r) * n / m)).cast<float>();
  return out;
}

}  // namespace

PairStrategy ParsePairStrategy(const std::string& name) {
  if (name == "exhaustive") return PairStrategy::kExhaustive;
  if (name == "sequential") return PairStrategy::kSequential;
  if (name == "retrieval") return PairStrategy::kRetrieval;
  if (name == "auto") return PairStrategy::kAuto;
  ThrowInputError("--pairs", "", "exhaustive, sequential, retrieval or auto, got \"" + name + "\"");
}

std::string PairStrategyName(PairStrategy strategy) {
  switch (strategy) {
    case PairStrategy::kExhaustive:
      return "exhaustive";
    case PairStrategy::kSequential:
      return "sequential";
    case PairStrategy::kRetrieval:
      return "retrieval";
    case PairStrategy::kAuto:
      return "auto";
  }
  throw std::logic_error("PairStrategyName: unknown strategy");
}

void PairSelectionOptions::Check() const {
  // Named by the command-line options where there are ones (--pairs, --overlap).
  if (overlap < 1) ThrowInputError("--overlap", "", ">= 1, got " + std::to_string(overlap));
  if (quadratic_overlap && overlap > 30)
    ThrowInputError("--overlap", "", "<= 30 with quadratic overlap (2^overlap places), got " + std::to_string(overlap));
  if (loop_detection_period < 0)
    ThrowInputError("loop_detection_period", "", ">= 0, got " + std::to_string(loop_detection_period));
  if (retrieval_neighbors < 1)
    ThrowInputError("retrieval_neighbors", "", ">= 1, got " + std::to_string(retrieval_neighbors));
  if (exhaustive_max_images < 0)
    ThrowInputError("exhaustive_max_images", "", ">= 0, got " + std::to_string(exhaustive_max_images));
  if (vocabulary_branching < 2)
    ThrowInputError("vocabulary_branching", "", ">= 2, got " + std::to_string(vocabulary_branching));
  if (vocabulary_depth < 1 || vocabulary_depth > 6)
    ThrowInputError("vocabulary_depth", "", "1..6, got " + std::to_string(vocabulary_depth));
  if (vocabulary_sample < vocabulary_branching)
    ThrowInputError("vocabulary_sample", "", ">= vocabulary_branching, got " + std::to_string(vocabulary_sample));
  if (kmeans_iterations < 1) ThrowInputError("kmeans_iterations", "", ">= 1, got " + std::to_string(kmeans_iterations));
  if (max_descriptors_per_image < 1)
    ThrowInputError("max_descriptors_per_image", "", ">= 1, got " + std::to_string(max_descriptors_per_image));
}

std::vector<int> NaturalNameOrder(const std::vector<std::string>& names) {
  std::vector<int> order(names.size());
  for (size_t k = 0; k < names.size(); ++k) order[k] = static_cast<int>(k);
  std::sort(order.begin(), order.end(), [&](int a, int b) {
    const int c = NaturalCompare(names[a], names[b]);
    return c != 0 ? c < 0 : a < b;
  });
  return order;
}

bool NamesLookNumbered(const std::vector<std::string>& names) {
  if (names.size() < 2) return false;
  std::string common;
  for (size_t k = 0; k < names.size(); ++k) {
    const std::string& n = names[k];
    size_t end = n.size();
    while (end > 0 && !std::isdigit(static_cast<unsigned char>(n[end - 1]))) --end;
    if (end == 0) return false;  // no digit
    size_t begin = end;
    while (begin > 0 && std::isdigit(static_cast<unsigned char>(n[begin - 1]))) --begin;
    const std::string rest = n.substr(0, begin) + "#" + n.substr(end);
    if (k == 0) common = rest;
    if (rest != common) return false;
  }
  return true;
}

std::vector<std::pair<int, int>> SequentialPairs(const std::vector<std::string>& names,
                                                 const PairSelectionOptions& options) {
  const std::vector<int> order = NaturalNameOrder(names);
  const int n = static_cast<int>(order.size());
  Pairs pairs;
  for (int p = 0; p < n; ++p) {
    for (int o = 1; o <= options.overlap && p + o < n; ++o) pairs.push_back({order[p], order[p + o]});
    if (options.quadratic_overlap)
      for (int e = 0; e < options.overlap && e < 31; ++e) {
        const int64_t q = p + (int64_t{1} << e);
        if (q >= n) break;
        pairs.push_back({order[p], order[q]});
      }
  }
  SortUnique(&pairs);
  return pairs;
}

Eigen::MatrixXf RetrievalSimilarity(const std::vector<SiftDescriptors>& descriptors,
                                    const PairSelectionOptions& options) {
  options.Check();
  const int n = static_cast<int>(descriptors.size());
  Eigen::MatrixXf similarity = Eigen::MatrixXf::Zero(n, n);
  int with_rows = 0;
  for (const auto& d : descriptors) with_rows += d.rows() > 0;
  if (with_rows == 0) return similarity;

  // The vocabulary's sample: an equal share of every image's kept rows, evenly strided.
  const int share = (options.vocabulary_sample + with_rows - 1) / with_rows;
  std::vector<DescriptorsF> kept(n);
  int sample_rows = 0;
  for (int i = 0; i < n; ++i) {
    kept[i] = Strided(descriptors[i], options.max_descriptors_per_image);
    sample_rows += std::min<int>(share, kept[i].rows());
  }
  DescriptorsF sample(sample_rows, 128);
  for (int i = 0, r = 0; i < n; ++i) {
    const int m = static_cast<int>(kept[i].rows()), take = std::min(share, m);
    for (int t = 0; t < take; ++t) sample.row(r++) = kept[i].row(static_cast<int>(static_cast<int64_t>(t) * m / take));
  }
  const VocabularyTree tree(sample, options);

  // Words of every image, in parallel (each image writes its own entry).
  std::vector<std::vector<int>> words(n);
  cv::parallel_for_(cv::Range(0, n), [&](const cv::Range& range) {
    for (int i = range.start; i < range.end; ++i) {
      words[i] = tree.Quantize(kept[i]);
      std::sort(words[i].begin(), words[i].end());
    }
  });

  // tf-idf: weight sqrt(count) * log(N / images holding the word), each image's vector of unit
  // length (the square root damps bursts of one repeated structure).
  std::vector<int> holders(tree.num_words(), 0);
  std::vector<std::vector<std::pair<int, float>>> bags(n);  // (word, count), then (word, weight)
  for (int i = 0; i < n; ++i) {
    for (size_t r = 0; r < words[i].size();) {
      size_t e = r;
      while (e < words[i].size() && words[i][e] == words[i][r]) ++e;
      bags[i].push_back({words[i][r], static_cast<float>(e - r)});
      ++holders[words[i][r]];
      r = e;
    }
  }
  std::vector<std::vector<std::pair<int, float>>> inverted(tree.num_words());  // (image, weight)
  for (int i = 0; i < n; ++i) {
    double norm2 = 0;
    for (auto& [w, v] : bags[i]) {
      v = std::sqrt(v) * static_cast<float>(std::log(static_cast<double>(n) / holders[w]));
      norm2 += static_cast<double>(v) * v;
    }
    if (!(norm2 > 0)) continue;
    similarity(i, i) = 1.f;
    const float inv = static_cast<float>(1.0 / std::sqrt(norm2));
    for (const auto& [w, v] : bags[i])
      if (v > 0) inverted[w].push_back({i, v * inv});
  }
  for (const auto& list : inverted)
    for (size_t a = 0; a < list.size(); ++a)
      for (size_t b = a + 1; b < list.size(); ++b)
        similarity(list[a].first, list[b].first) += list[a].second * list[b].second;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) similarity(j, i) = similarity(i, j);
  return similarity;
}

std::vector<std::pair<int, int>> NearestPairs(const Eigen::MatrixXf& similarity, const std::vector<int>& images,
                                              int k) {
  const int n = static_cast<int>(similarity.rows());
  Pairs pairs;
  std::vector<std::pair<float, int>> scored;
  for (int i : images) {
    scored.clear();
    for (int j = 0; j < n; ++j)
      if (j != i && similarity(i, j) > 0) scored.push_back({-similarity(i, j), j});
    const int take = std::min<int>(k, scored.size());
    std::partial_sort(scored.begin(), scored.begin() + take, scored.end());
    for (int t = 0; t < take; ++t) pairs.push_back({i, scored[t].second});
  }
  SortUnique(&pairs);
  return pairs;
}

std::vector<std::pair<int, int>> SelectPairs(const std::vector<SiftDescriptors>& descriptors,
                                             const std::vector<std::string>& names,
                                             const PairSelectionOptions& options) {
  options.Check();
  if (descriptors.size() != names.size())
    throw std::invalid_argument("SelectPairs: " + std::to_string(descriptors.size()) + " descriptor sets for " +
                                std::to_string(names.size()) + " names");
  const int n = static_cast<int>(names.size());
  PairStrategy strategy = options.strategy;
  bool add_sequential = false;
  if (strategy == PairStrategy::kAuto) {
    strategy = n <= options.exhaustive_max_images ? PairStrategy::kExhaustive : PairStrategy::kRetrieval;
    add_sequential = strategy == PairStrategy::kRetrieval && NamesLookNumbered(names);
  }
  Pairs pairs;
  if (strategy == PairStrategy::kExhaustive) {
    for (int i = 0; i < n; ++i)
      for (int j = i + 1; j < n; ++j) pairs.push_back({i, j});
  } else if (strategy == PairStrategy::kSequential) {
    pairs = SequentialPairs(names, options);
    if (options.loop_detection_period > 0 && n > options.overlap + 1) {
      const std::vector<int> order = NaturalNameOrder(names);
      std::vector<int> loop_images;
      for (int p = 0; p < n; p += options.loop_detection_period) loop_images.push_back(order[p]);
      const Pairs loops =
          NearestPairs(RetrievalSimilarity(descriptors, options), loop_images, options.retrieval_neighbors);
      pairs.insert(pairs.end(), loops.begin(), loops.end());
    }
  } else {
    std::vector<int> all(n);
    for (int i = 0; i < n; ++i) all[i] = i;
    pairs = NearestPairs(RetrievalSimilarity(descriptors, options), all, options.retrieval_neighbors);
    if (add_sequential) {
      const Pairs seq = SequentialPairs(names, options);
      pairs.insert(pairs.end(), seq.begin(), seq.end());
    }
  }
  SortUnique(&pairs);
  LOG_INFO("pairs: {}{}{}: {} of {} pairs", PairStrategyName(options.strategy),
           options.strategy == PairStrategy::kAuto ? " -> " + PairStrategyName(strategy) : std::string(),
           add_sequential ? " + sequential (numbered names)" : "", pairs.size(), static_cast<int64_t>(n) * (n - 1) / 2);
  return pairs;
}

}  // namespace nerfreg
