#include "slideplan/straight_line.hpp"

#include <algorithm>
#include <cmath>
#include <random>

namespace slideplan
{
    std::optional<std::vector<Eigen::VectorXd>> straightLine(const RobotModel &robot, const Eigen::VectorXd &q,
                                                             const Eigen::Isometry3d &start, const Eigen::Vector3d &offset,
                                                             const IkOptions &options, std::uint64_t rngSeed,
                                                             const std::string &link, const Eigen::Isometry3d &frame)
    {
        const int steps = std::max(1, static_cast<int>(std::ceil(offset.norm() / kLiftStep - 1e-9)));
        std::vector<Eigen::VectorXd> path;
        path.reserve(steps + 1);
        path.push_back(q);
        for (int step = 1; step <= steps; ++step)
        {
            Eigen::Isometry3d target = start;
            target.translation() += offset * static_cast<double>(step) / static_cast<double>(steps);
            std::mt19937_64 rng(rngSeed);
            Eigen::VectorXd next;
            const bool solved = link.empty() ? robot.ik(target, path.back(), rng, next, options)
                                             : robot.ikForLink(link, target, path.back(), rng, next, options, frame);
            if (!solved || (next - path.back()).cwiseAbs().maxCoeff() > kLiftJointStep)
                return std::nullopt;
            path.push_back(std::move(next));
        }
        return path;
    }
}  // namespace slideplan
