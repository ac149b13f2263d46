/// \file outline_icp.hpp
/// Trimmed 2-D ICP of a depth frame's object-table edge points to the object's known outline: the
/// registration step of the closed loop's tracker (python/slideplan/tracking.py, beyond the paper).
#pragma once

#include "slideplan/area_centroid.hpp"

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <vector>

namespace slideplan
{
    /// One start's fit: the planar motion (x, y, yaw) taking the reference outline to the edge points,
    /// how many edge points lie within the inlier distance of it, and their root mean square distance
    /// (infinite with none).
    struct OutlineFit
    {
        Eigen::Vector3d motion;
        int inliers = 0;
        double rmse = 0.0;
    };

    /// Nearest outline points, exactly (a k-d tree) or by a precomputed grid, and trimmed ICP from
    /// several starts. Immutable once made: one instance may serve many threads.
    class OutlineIcp
    {
    public:
        using IndexGrid = Eigen::Matrix<std::int64_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

        /// \param model the outline's points (M, 2) in the reference frame.
        /// \param grid for each cell of a grid over the plane (cell (i, j) spans x from low.x + i cell,
        ///        y from low.y + j cell), the index into \p model of the outline point nearest it; a point
        ///        beyond the grid takes its border cell's.
        /// \param low the grid's corner.
        /// \param cell the grid's cell size (m).
        /// \param inlier an edge point this near the outline is explained by it (m).
        /// \throws std::invalid_argument for no model points, a non-finite value, an empty grid or one
        ///         with an index outside the model, or a cell or inlier distance that is not positive.
        OutlineIcp(Points2 model, IndexGrid grid, const Eigen::Vector2d &low, double cell, double inlier);
        ~OutlineIcp();
        OutlineIcp(const OutlineIcp &) = delete;
        OutlineIcp &operator=(const OutlineIcp &) = delete;

        /// Distance to, and index of, the outline point nearest each of \p points brought into the
        /// reference frame by the inverse of \p motion.
        /// \param exact false: by the grid (within a cell of the nearest).
        void nearest(const Points2 &points, const Eigen::Vector3d &motion, bool exact, Eigen::VectorXd &distance,
                     Eigen::VectorXi &index) const;

        /// Trimmed ICP from each start: per iteration, each edge point is paired with its nearest outline
        /// point, pairs farther than the gate are dropped, and the rigid motion that best maps the kept
        /// outline points onto their edge points (least squares in closed form, the 2-D Kabsch solution)
        /// is the next estimate; the gate is then three times the kept pairs' median distance (at least
        /// the inlier distance). A start stops when it moves less than 0.01 mm and 0.1 mrad, or keeps
        /// fewer than 3 pairs.
        /// \param points the edge points (N, 2), world frame.
        /// \param starts motions (S, 3) to start from.
        /// \param iterations at most this many per start.
        /// \param exact false: iterations pair by the grid (scouting); the final count is exact either way.
        /// \param gate the first iteration's gate (m): a start may be centimetres off.
        /// \throws std::invalid_argument for a non-finite point or start, or iterations < 0.
        std::vector<OutlineFit> fit(const Points2 &points, const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> &starts,
                                    int iterations, bool exact, double gate) const;

    private:
        struct Tree;
        Points2 model_;
        IndexGrid grid_;
        Eigen::Vector2d low_;
        double cell_;
        double inlier_;
        std::unique_ptr<Tree> tree_;  ///< built over model_, which therefore never moves
    };
}  // namespace slideplan
