#pragma once
// The Ceres set-up every least-squares problem of nerfreg solves with (pose graphs, rotation and
// translation averaging, bundle adjustment), written once. Include it from .cc files only: the
// libraries link Ceres privately.
#include <ceres/ceres.h>

namespace nerfreg {

// Solves `problem` with a sparse linear solver (SPARSE_NORMAL_CHOLESKY, or SPARSE_SCHUR for bundle
// adjustment's camera / point structure), at most max_iterations Levenberg-Marquardt steps.
inline ceres::Solver::Summary SolveCeresProblem(ceres::Problem* problem, int max_iterations,
                                                ceres::LinearSolverType linear_solver = ceres::SPARSE_NORMAL_CHOLESKY,
                                                int num_threads = 1) {
  ceres::Solver::Options solver;
  solver.max_num_iterations = max_iterations;
  solver.linear_solver_type = linear_solver;
  solver.num_threads = num_threads;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, problem, &summary);
  return summary;
}

}  // namespace nerfreg
