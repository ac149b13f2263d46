#include "slideplan/outline_icp.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <nanoflann.hpp>
#include <stdexcept>

namespace slideplan
{
    namespace
    {
        constexpr double kStillM = 1e-5;    ///< a start moving less than this (and kStillRad) is done
        constexpr double kStillRad = 1e-4;
        constexpr double kGateFactor = 3.0;  ///< pairs beyond this many median distances are dropped
        constexpr int kMinPairs = 3;

        /// Median of the values (reordered), the two middle ones averaged for an even count.
        double median(std::vector<double> &values)
        {
            const std::size_t n = values.size();
            std::sort(values.begin(), values.end());
            return 0.5 * (values[(n - 1) / 2] + values[n / 2]);
        }
    }  // namespace

    struct OutlineIcp::Tree
    {
        using Index = nanoflann::KDTreeEigenMatrixAdaptor<Points2, 2, nanoflann::metric_L2>;
        explicit Tree(const Points2 &model) : index(2, std::cref(model), 10) {}
        Index index;
    };

    OutlineIcp::OutlineIcp(Points2 model, IndexGrid grid, const Eigen::Vector2d &low, double cell, double inlier)
      : model_(std::move(model)), grid_(std::move(grid)), low_(low), cell_(cell), inlier_(inlier)
    {
        if (model_.rows() == 0 || !model_.allFinite())
            throw std::invalid_argument("outline ICP: the model needs points, all finite");
        if (grid_.size() == 0 || grid_.minCoeff() < 0 || grid_.maxCoeff() >= model_.rows())
            throw std::invalid_argument("outline ICP: the grid must be non-empty and index the model's points");
        if (!low_.allFinite() || !(cell_ > 0.0) || !std::isfinite(cell_) || !(inlier_ > 0.0) || !std::isfinite(inlier_))
            throw std::invalid_argument("outline ICP: the grid's corner must be finite, its cell and the inlier distance positive");
        tree_ = std::make_unique<Tree>(model_);
    }

    OutlineIcp::~OutlineIcp() = default;

    void OutlineIcp::nearest(const Points2 &points, const Eigen::Vector3d &motion, bool exact, Eigen::VectorXd &distance,
                             Eigen::VectorXi &index) const
    {
        const double c = std::cos(motion.z()), s = std::sin(motion.z());
        distance.resize(points.rows());
        index.resize(points.rows());
        for (Eigen::Index i = 0; i < points.rows(); ++i)
        {
            const double dx = points(i, 0) - motion.x(), dy = points(i, 1) - motion.y();
            const double local[2] = {dx * c + dy * s, dy * c - dx * s};
            Eigen::Index nearestIndex = 0;
            if (exact)
            {
                double squared = 0.0;
                tree_->index.query(local, 1, &nearestIndex, &squared);
            }
            else
            {
                const auto cellOf = [&](int axis, Eigen::Index size) {
                    const double at = std::floor((local[axis] - low_(axis)) / cell_);
                    return static_cast<Eigen::Index>(std::clamp(at, 0.0, static_cast<double>(size - 1)));
                };
                nearestIndex = grid_(cellOf(0, grid_.rows()), cellOf(1, grid_.cols()));
            }
            index(i) = static_cast<int>(nearestIndex);
            distance(i) = std::hypot(local[0] - model_(nearestIndex, 0), local[1] - model_(nearestIndex, 1));
        }
    }

    std::vector<OutlineFit> OutlineIcp::fit(const Points2 &points, const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> &starts,
                                            int iterations, bool exact, double gate) const
    {
        if (!points.allFinite() || !starts.allFinite())
            throw std::invalid_argument("outline ICP: the edge points and starts must be finite");
        if (iterations < 0)
            throw std::invalid_argument("outline ICP: iterations must not be negative");
        std::vector<OutlineFit> fits;
        Eigen::VectorXd distance;
        Eigen::VectorXi index;
        std::vector<double> kept;
        for (Eigen::Index start = 0; start < starts.rows(); ++start)
        {
            Eigen::Vector3d motion = starts.row(start).transpose();
            double startGate = gate;
            for (int iteration = 0; iteration < iterations; ++iteration)
            {
                nearest(points, motion, exact, distance, index);
                // The kept pairs' means, then the turn between them (2-D Kabsch).
                Eigen::Vector2d sourceMean = Eigen::Vector2d::Zero(), targetMean = Eigen::Vector2d::Zero();
                kept.clear();
                for (Eigen::Index i = 0; i < points.rows(); ++i)
                    if (distance(i) <= startGate)
                    {
                        kept.push_back(distance(i));
                        sourceMean += model_.row(index(i)).transpose();
                        targetMean += points.row(i).transpose();
                    }
                if (static_cast<int>(kept.size()) < kMinPairs)
                    break;
                sourceMean /= static_cast<double>(kept.size());
                targetMean /= static_cast<double>(kept.size());
                double cross = 0.0, dot = 0.0;
                for (Eigen::Index i = 0; i < points.rows(); ++i)
                    if (distance(i) <= startGate)
                    {
                        const Eigen::Vector2d a = model_.row(index(i)).transpose() - sourceMean;
                        const Eigen::Vector2d b = points.row(i).transpose() - targetMean;
                        cross += a.x() * b.y() - a.y() * b.x();
                        dot += a.x() * b.x() + a.y() * b.y();
                    }
                const double yaw = std::atan2(cross, dot), c = std::cos(yaw), s = std::sin(yaw);
                const Eigen::Vector3d step(targetMean.x() - (c * sourceMean.x() - s * sourceMean.y()),
                                           targetMean.y() - (s * sourceMean.x() + c * sourceMean.y()), yaw);
                const Eigen::Vector3d change = (step - motion).cwiseAbs();
                motion = step;
                startGate = std::max(kGateFactor * median(kept), inlier_);
                if (std::max(change.x(), change.y()) < kStillM && change.z() < kStillRad)
                    break;
            }
            nearest(points, motion, true, distance, index);
            OutlineFit fit{motion, 0, 0.0};
            double squared = 0.0;
            for (Eigen::Index i = 0; i < points.rows(); ++i)
                if (distance(i) <= inlier_)
                {
                    ++fit.inliers;
                    squared += distance(i) * distance(i);
                }
            fit.rmse = fit.inliers ? std::sqrt(squared / fit.inliers) : std::numeric_limits<double>::infinity();
            fits.push_back(fit);
        }
        return fits;
    }
}  // namespace slideplan
