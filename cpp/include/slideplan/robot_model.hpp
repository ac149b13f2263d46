/// \file robot_model.hpp
/// The arm: URDF (urdfdom) -> KDL chain; Gamma(phi) (forward kinematics to a named frame), its
/// geometric Jacobian, and Gamma~(omega) (inverse kinematics, written here: DESIGN.md 7 forbids
/// KDL's SVD-based solvers).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <kdl/chain.hpp>
#include <kdl/segment.hpp>
#include <memory>
#include <random>
#include <string>
#include <vector>

namespace slideplan
{
    /// One collision primitive of a link, posed in the link frame.
    struct LinkShape
    {
        enum class Type
        {
            Box,
            Cylinder,
            Sphere
        };
        Type type;
        Eigen::Vector3d size;  ///< box: full extents; cylinder: (radius, length, 0); sphere: (radius, 0, 0)
        Eigen::Isometry3d origin{Eigen::Isometry3d::Identity()};
    };

    /// A link of the robot tree with its collision primitives.
    struct RobotLink
    {
        std::string name;
        int parent{-1};       ///< index into RobotModel::links(), -1 for the root
        int jointIndex{-1};   ///< index into the chain's joint vector, -1 if the joint is fixed or off the chain
        KDL::Segment segment; ///< joint and origin relative to the parent link
        std::vector<LinkShape> shapes;
    };

    /// Options of the damped-least-squares inverse kinematics.
    struct IkOptions
    {
        int maxIterations{100};          ///< per attempt
        int maxAttempts{50};             ///< the seed, then random restarts
        double positionTolerance{1e-8};  ///< metres
        double orientationTolerance{1e-8};  ///< radians
    };

    /// A serial arm from a URDF, moving the frame `tipLink`; every link is kept for collision checking.
    class RobotModel
    {
    public:
        /// \param urdfXml   the URDF text
        /// \param tipLink   the frame Gamma() moves (the chain runs from the URDF root to it)
        /// \param basePose  world pose of the URDF root link
        /// \param source    file name used in error messages
        /// \throws std::invalid_argument on malformed URDF, unknown tip link, unsupported geometry.
        RobotModel(const std::string &urdfXml, const std::string &tipLink,
                   const Eigen::Isometry3d &basePose = Eigen::Isometry3d::Identity(),
                   const std::string &source = "<urdf>");

        static RobotModel fromFile(const std::string &path, const std::string &tipLink,
                                   const Eigen::Isometry3d &basePose = Eigen::Isometry3d::Identity());

        unsigned int dof() const { return chain_.getNrOfJoints(); }
        const std::vector<std::string> &jointNames() const { return jointNames_; }
        const Eigen::VectorXd &lowerLimits() const { return lower_; }
        const Eigen::VectorXd &upperLimits() const { return upper_; }
        const std::string &tipLink() const { return tipLink_; }
        const Eigen::Isometry3d &basePose() const { return basePose_; }
        bool withinLimits(const Eigen::VectorXd &q, double tolerance = 1e-9) const;

        /// Gamma(phi): world pose of the tip frame.
        Eigen::Isometry3d fk(const Eigen::VectorXd &q) const;

        /// World pose of any link, e.g. the grasp frame `t42_grasp`.
        /// \throws std::invalid_argument for an unknown link.
        Eigen::Isometry3d linkPose(const Eigen::VectorXd &q, const std::string &link) const;

        /// Geometric Jacobian of the tip frame in the world frame (rows: linear, angular velocity).
        Eigen::Matrix<double, 6, Eigen::Dynamic> jacobian(const Eigen::VectorXd &q) const;

        /// World poses of all links, indexed like links().
        void linkPoses(const Eigen::VectorXd &q, std::vector<Eigen::Isometry3d> &poses) const;

        /// Gamma~(omega): a configuration within the joint limits whose tip pose equals target.
        /// Damped least squares (Levenberg-Marquardt damping), starting from `seed`, then from random
        /// configurations drawn from `rng`. Returns false if no attempt converged.
        bool ik(const Eigen::Isometry3d &target, const Eigen::VectorXd &seed, std::mt19937_64 &rng,
                Eigen::VectorXd &solution, const IkOptions &options = IkOptions()) const;

        /// The same, for a link moved by exactly the tip chain's joints (e.g. a grasp frame on the palm).
        /// \throws std::invalid_argument if the link is unknown or moved by other joints.
        bool ikForLink(const std::string &link, const Eigen::Isometry3d &target, const Eigen::VectorXd &seed,
                       std::mt19937_64 &rng, Eigen::VectorXd &solution, const IkOptions &options = IkOptions()) const;

        Eigen::VectorXd randomConfiguration(std::mt19937_64 &rng) const;

        const std::vector<RobotLink> &links() const { return links_; }
        int linkIndex(const std::string &name) const;  ///< -1 if unknown

    private:
        KDL::Chain chainTo(const std::string &link) const;
        const KDL::Chain &ikChain(const std::string &link) const;
        bool solveIk(const KDL::Chain &chain, const Eigen::Isometry3d &target, const Eigen::VectorXd &seed,
                     std::mt19937_64 &rng, Eigen::VectorXd &solution, const IkOptions &options) const;
        Eigen::Isometry3d chainFk(const KDL::Chain &chain, const Eigen::VectorXd &q) const;
        Eigen::Matrix<double, 6, Eigen::Dynamic> chainJacobian(const KDL::Chain &chain, const Eigen::VectorXd &q) const;

        std::string source_;
        std::string tipLink_;
        Eigen::Isometry3d basePose_;
        KDL::Chain chain_;
        std::vector<std::string> jointNames_;
        Eigen::VectorXd lower_, upper_;
        std::vector<RobotLink> links_;  ///< topological order: parents before children
        std::vector<std::pair<std::string, KDL::Chain>> ikChains_;  ///< links moved by exactly the tip joints
    };

    /// 6-vector pose error (position, rotation vector) of `current` towards `target`, world frame.
    Eigen::Matrix<double, 6, 1> poseError(const Eigen::Isometry3d &current, const Eigen::Isometry3d &target);

}  // namespace slideplan
