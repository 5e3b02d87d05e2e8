#pragma once
// A trained block's surface as a coloured triangle mesh: the density sampled on a regular grid of
// vertices over the block's AABB, marching cubes at a density threshold (Lorensen & Cline; the
// edge / triangle tables are Paul Bourke's, as shipped by Open3D), shared vertices per grid
// edge, vertex colours from the field looking at the surface along the inward normal.
#include <torch/torch.h>

#include <string>
#include <vector>

#include "nerfreg/nerf/nerf_block.h"

namespace nerfreg {

struct MeshExportOptions {
  int resolution = 128;            // grid cells per axis (the density is sampled at resolution + 1 vertices)
  double density_threshold = 2.5;  // iso-level on sigma (instant-ngp's default for its mesh export)
  void Check() const;              // throws InputError naming the option
};

struct ColoredMesh {
  torch::Tensor vertices;   // [V, 3] float32, block frame
  torch::Tensor normals;    // [V, 3] float32, unit, outward (towards lower density)
  torch::Tensor colors;     // [V, 3] float32 in [0, 1]
  torch::Tensor triangles;  // [T, 3] int64, counter-clockwise seen from outside
};

// Marching cubes on `values` [G+1, G+1, G+1] (x, y, z indexed; float32) sampled at the vertices
// of a regular grid spanning [box_min, box_max]. The surface separates values > iso (inside) from
// values <= iso. Returns vertices and triangles only (no normals or colours).
ColoredMesh MarchingCubes(const torch::Tensor& values, double iso, const std::vector<double>& box_min,
                          const std::vector<double>& box_max);

// Area-weighted vertex normals of a triangle mesh, oriented by the triangles' winding.
torch::Tensor VertexNormals(const torch::Tensor& vertices, const torch::Tensor& triangles);

// Samples the block's density, extracts the iso-surface and colours it.
ColoredMesh ExtractMesh(NerfBlock& block, const MeshExportOptions& options);

// Binary little-endian PLY with per-vertex normals and colours, written atomically.
void WriteMeshPly(const ColoredMesh& mesh, const std::string& path);

}  // namespace nerfreg
