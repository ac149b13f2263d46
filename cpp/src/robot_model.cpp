#include "slideplan/robot_model.hpp"

#include <algorithm>
#include <fstream>
#include <kdl/chainfksolverpos_recursive.hpp>
#include <kdl/chainjnttojacsolver.hpp>
#include <map>
#include <sstream>
#include <stdexcept>
#include <urdf_parser/urdf_parser.h>

namespace slideplan
{
    namespace
    {
        KDL::Frame toKdl(const urdf::Pose &pose)
        {
            double x, y, z, w;
            pose.rotation.getQuaternion(x, y, z, w);
            return {KDL::Rotation::Quaternion(x, y, z, w), KDL::Vector(pose.position.x, pose.position.y, pose.position.z)};
        }

        Eigen::Isometry3d toEigen(const KDL::Frame &frame)
        {
            Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
            for (int r = 0; r < 3; ++r)
            {
                out.translation()(r) = frame.p(r);
                for (int c = 0; c < 3; ++c)
                    out.linear()(r, c) = frame.M(r, c);
            }
            return out;
        }

        Eigen::Isometry3d toEigen(const urdf::Pose &pose)
        {
            return toEigen(toKdl(pose));
        }

        /// The KDL joint for a URDF joint, expressed in the parent link frame as kdl_parser does.
        KDL::Joint toKdlJoint(const urdf::Joint &joint)
        {
            const KDL::Frame origin = toKdl(joint.parent_to_joint_origin_transform);
            const KDL::Vector axis(joint.axis.x, joint.axis.y, joint.axis.z);
            switch (joint.type)
            {
                case urdf::Joint::REVOLUTE:
                case urdf::Joint::CONTINUOUS:
                    return KDL::Joint(joint.name, origin.p, origin.M * axis, KDL::Joint::RotAxis);
                case urdf::Joint::PRISMATIC:
                    return KDL::Joint(joint.name, origin.p, origin.M * axis, KDL::Joint::TransAxis);
                case urdf::Joint::FIXED:
                    return KDL::Joint(joint.name, KDL::Joint::None);
                default:
                    throw std::invalid_argument("joint '" + joint.name + "': only revolute, continuous, prismatic and fixed joints are supported");
            }
        }

        void addShape(const std::string &source, const std::string &link, const urdf::Collision &collision,
                      std::vector<LinkShape> &shapes)
        {
            if (!collision.geometry)
                return;
            LinkShape shape;
            shape.origin = toEigen(collision.origin);
            shape.size.setZero();
            switch (collision.geometry->type)
            {
                case urdf::Geometry::BOX:
                {
                    const auto &box = static_cast<const urdf::Box &>(*collision.geometry);
                    shape.type = LinkShape::Type::Box;
                    shape.size = Eigen::Vector3d(box.dim.x, box.dim.y, box.dim.z);
                    break;
                }
                case urdf::Geometry::CYLINDER:
                {
                    const auto &cylinder = static_cast<const urdf::Cylinder &>(*collision.geometry);
                    shape.type = LinkShape::Type::Cylinder;
                    shape.size = Eigen::Vector3d(cylinder.radius, cylinder.length, 0.0);
                    break;
                }
                case urdf::Geometry::SPHERE:
                {
                    shape.type = LinkShape::Type::Sphere;
                    shape.size.x() = static_cast<const urdf::Sphere &>(*collision.geometry).radius;
                    break;
                }
                default:
                    throw std::invalid_argument(source + ": link '" + link +
                                                "': mesh collision geometry is not supported; use box, cylinder or sphere primitives");
            }
            if (!shape.size.allFinite() || (shape.size.array() < 0).any() || !shape.origin.matrix().allFinite())
                throw std::invalid_argument(source + ": link '" + link + "': collision geometry has a negative or non-finite size");
            shapes.push_back(shape);
        }
    }  // namespace

    Eigen::Matrix<double, 6, 1> poseError(const Eigen::Isometry3d &current, const Eigen::Isometry3d &target)
    {
        Eigen::Matrix<double, 6, 1> error;
        error.head<3>() = target.translation() - current.translation();
        const Eigen::AngleAxisd rotation(target.linear() * current.linear().transpose());
        error.tail<3>() = rotation.angle() * rotation.axis();
        return error;
    }

    RobotModel::RobotModel(const std::string &urdfXml, const std::string &tipLink, const Eigen::Isometry3d &basePose,
                           const std::string &source)
      : source_(source), tipLink_(tipLink), basePose_(basePose)
    {
        if (!basePose.matrix().allFinite())
            throw std::invalid_argument(source + ": base pose is not finite");
        // urdfdom reports parse errors on stderr and returns null; it can also throw on bad numbers.
        urdf::ModelInterfaceSharedPtr model;
        try
        {
            model = urdf::parseURDF(urdfXml);
        }
        catch (const std::exception &error)
        {
            throw std::invalid_argument(source + ": malformed URDF: " + error.what());
        }
        if (!model || !model->getRoot())
            throw std::invalid_argument(source + ": malformed URDF (urdfdom could not parse it)");

        // Links in topological order, parents first.
        std::map<std::string, int> index;
        std::vector<urdf::LinkConstSharedPtr> stack{model->getRoot()};
        while (!stack.empty())
        {
            const urdf::LinkConstSharedPtr link = stack.back();
            stack.pop_back();
            RobotLink entry;
            entry.name = link->name;
            if (link->parent_joint)
            {
                entry.parent = index.at(link->getParent()->name);
                const urdf::Joint &joint = *link->parent_joint;
                entry.segment = KDL::Segment(link->name, toKdlJoint(joint), toKdl(joint.parent_to_joint_origin_transform));
            }
            else
                entry.segment = KDL::Segment(link->name, KDL::Joint(KDL::Joint::None));
            for (const auto &collision : link->collision_array)
                addShape(source, link->name, *collision, entry.shapes);
            if (link->collision_array.empty() && link->collision)
                addShape(source, link->name, *link->collision, entry.shapes);
            index[link->name] = static_cast<int>(links_.size());
            links_.push_back(std::move(entry));
            for (auto it = link->child_links.rbegin(); it != link->child_links.rend(); ++it)
                stack.push_back(*it);
        }
        if (linkIndex(tipLink) < 0)
            throw std::invalid_argument(source + ": tip link '" + tipLink + "' is not a link of the URDF");

        chain_ = chainTo(tipLink);
        if (chain_.getNrOfJoints() == 0)
            throw std::invalid_argument(source + ": no movable joint between the root and '" + tipLink + "'");

        // Joint names, limits and each link's index into q.
        std::map<std::string, int> chainJoint;
        lower_.resize(chain_.getNrOfJoints());
        upper_.resize(chain_.getNrOfJoints());
        for (const KDL::Segment &segment : chain_.segments)
        {
            if (segment.getJoint().getType() == KDL::Joint::None)
                continue;
            const int i = static_cast<int>(jointNames_.size());
            const std::string &name = segment.getJoint().getName();
            const urdf::JointConstSharedPtr joint = model->getJoint(name);
            double lower = -M_PI, upper = M_PI;  // continuous joints: one turn each way suffices
            if (joint->type != urdf::Joint::CONTINUOUS)
            {
                if (!joint->limits)
                    throw std::invalid_argument(source + ": joint '" + name + "' has no <limit>");
                lower = joint->limits->lower;
                upper = joint->limits->upper;
                if (!(lower <= upper) || !std::isfinite(lower) || !std::isfinite(upper))
                    throw std::invalid_argument(source + ": joint '" + name + "' has invalid limits");
            }
            lower_(i) = lower;
            upper_(i) = upper;
            jointNames_.push_back(name);
            chainJoint[name] = i;
        }
        for (RobotLink &link : links_)
        {
            const auto it = chainJoint.find(link.segment.getJoint().getName());
            if (link.segment.getJoint().getType() != KDL::Joint::None && it != chainJoint.end())
                link.jointIndex = it->second;
            // Movable joints off the chain (e.g. finger joints) stay at 0: the hand's compliance is
            // modelled by the planner's relaxations, not by joints.
        }
        for (const RobotLink &link : links_)
        {
            KDL::Chain chain = chainTo(link.name);
            if (chain.getNrOfJoints() != dof())
                continue;
            bool same = true;
            for (unsigned s = 0, j = 0; s < chain.getNrOfSegments(); ++s)
                if (chain.getSegment(s).getJoint().getType() != KDL::Joint::None)
                    same = same && chain.getSegment(s).getJoint().getName() == jointNames_[j++];
            if (same)
                ikChains_.emplace_back(link.name, std::move(chain));
        }
    }

    RobotModel RobotModel::fromFile(const std::string &path, const std::string &tipLink, const Eigen::Isometry3d &basePose)
    {
        std::ifstream file(path);
        if (!file)
            throw std::invalid_argument(path + ": cannot open URDF file");
        std::stringstream text;
        text << file.rdbuf();
        return RobotModel(text.str(), tipLink, basePose, path);
    }

    int RobotModel::linkIndex(const std::string &name) const
    {
        for (std::size_t i = 0; i < links_.size(); ++i)
            if (links_[i].name == name)
                return static_cast<int>(i);
        return -1;
    }

    KDL::Chain RobotModel::chainTo(const std::string &link) const
    {
        std::vector<int> path;
        for (int i = linkIndex(link); i > 0; i = links_[i].parent)
            path.push_back(i);
        KDL::Chain chain;
        for (auto it = path.rbegin(); it != path.rend(); ++it)
            chain.addSegment(links_[*it].segment);
        return chain;
    }

    const KDL::Chain &RobotModel::ikChain(const std::string &link) const
    {
        for (const auto &[name, chain] : ikChains_)
            if (name == link)
                return chain;
        throw std::invalid_argument(source_ + ": link '" + link + "' is unknown or not moved by exactly the joints of the chain to '" + tipLink_ + "'");
    }

    bool RobotModel::withinLimits(const Eigen::VectorXd &q, double tolerance) const
    {
        return q.size() == lower_.size() && (q.array() >= lower_.array() - tolerance).all() &&
               (q.array() <= upper_.array() + tolerance).all();
    }

    Eigen::Isometry3d RobotModel::chainFk(const KDL::Chain &chain, const Eigen::VectorXd &q) const
    {
        KDL::ChainFkSolverPos_recursive solver(chain);
        KDL::JntArray joints(chain.getNrOfJoints());
        joints.data = q;
        KDL::Frame frame;
        solver.JntToCart(joints, frame);
        return basePose_ * toEigen(frame);
    }

    Eigen::Matrix<double, 6, Eigen::Dynamic> RobotModel::chainJacobian(const KDL::Chain &chain, const Eigen::VectorXd &q) const
    {
        KDL::ChainJntToJacSolver solver(chain);
        KDL::JntArray joints(chain.getNrOfJoints());
        joints.data = q;
        KDL::Jacobian jacobian(chain.getNrOfJoints());
        solver.JntToJac(joints, jacobian);
        Eigen::Matrix<double, 6, Eigen::Dynamic> world(6, chain.getNrOfJoints());
        const Eigen::Matrix3d rotation = basePose_.linear();
        world.topRows<3>() = rotation * jacobian.data.topRows<3>();
        world.bottomRows<3>() = rotation * jacobian.data.bottomRows<3>();
        return world;
    }

    Eigen::Isometry3d RobotModel::fk(const Eigen::VectorXd &q) const
    {
        return chainFk(chain_, q);
    }

    Eigen::Matrix<double, 6, Eigen::Dynamic> RobotModel::jacobian(const Eigen::VectorXd &q) const
    {
        return chainJacobian(chain_, q);
    }

    Eigen::Isometry3d RobotModel::linkPose(const Eigen::VectorXd &q, const std::string &link) const
    {
        const int index = linkIndex(link);
        if (index < 0)
            throw std::invalid_argument(source_ + ": unknown link '" + link + "'");
        std::vector<Eigen::Isometry3d> poses;
        linkPoses(q, poses);
        return poses[index];
    }

    void RobotModel::linkPoses(const Eigen::VectorXd &q, std::vector<Eigen::Isometry3d> &poses) const
    {
        poses.resize(links_.size());
        for (std::size_t i = 0; i < links_.size(); ++i)
        {
            const RobotLink &link = links_[i];
            if (link.parent < 0)
            {
                poses[i] = basePose_;
                continue;
            }
            const double value = link.jointIndex >= 0 ? q(link.jointIndex) : 0.0;
            poses[i] = poses[link.parent] * toEigen(link.segment.pose(value));
        }
    }

    Eigen::VectorXd RobotModel::randomConfiguration(std::mt19937_64 &rng) const
    {
        std::uniform_real_distribution<double> unit(0.0, 1.0);
        Eigen::VectorXd q(dof());
        for (unsigned i = 0; i < dof(); ++i)
            q(i) = lower_(i) + unit(rng) * (upper_(i) - lower_(i));
        return q;
    }

    bool RobotModel::ik(const Eigen::Isometry3d &target, const Eigen::VectorXd &seed, std::mt19937_64 &rng,
                        Eigen::VectorXd &solution, const IkOptions &options) const
    {
        return solveIk(chain_, target, seed, rng, solution, options);
    }

    bool RobotModel::ikForLink(const std::string &link, const Eigen::Isometry3d &target, const Eigen::VectorXd &seed,
                               std::mt19937_64 &rng, Eigen::VectorXd &solution, const IkOptions &options) const
    {
        return solveIk(ikChain(link), target, seed, rng, solution, options);
    }

    bool RobotModel::solveIk(const KDL::Chain &chain, const Eigen::Isometry3d &target, const Eigen::VectorXd &seed,
                             std::mt19937_64 &rng, Eigen::VectorXd &solution, const IkOptions &options) const
    {
        if (!target.matrix().allFinite())
            return false;
        const auto converged = [&](const Eigen::Matrix<double, 6, 1> &error) {
            return error.head<3>().norm() < options.positionTolerance && error.tail<3>().norm() < options.orientationTolerance;
        };
        for (int attempt = 0; attempt < options.maxAttempts; ++attempt)
        {
            Eigen::VectorXd q = attempt == 0 && seed.size() == static_cast<long>(dof()) ? seed : randomConfiguration(rng);
            q = q.cwiseMax(lower_).cwiseMin(upper_);
            Eigen::Matrix<double, 6, 1> error = poseError(chainFk(chain, q), target);
            double cost = error.squaredNorm();
            // Levenberg-Marquardt damping: shrink after a good step, grow after a bad one.
            double lambda = 1e-2;
            for (int iteration = 0; iteration < options.maxIterations && !converged(error); ++iteration)
            {
                const Eigen::Matrix<double, 6, Eigen::Dynamic> jac = chainJacobian(chain, q);
                const Eigen::Matrix<double, 6, 6> jjt = jac * jac.transpose() + lambda * Eigen::Matrix<double, 6, 6>::Identity();
                const Eigen::VectorXd step = jac.transpose() * jjt.ldlt().solve(error);
                const Eigen::VectorXd candidate = (q + step).cwiseMax(lower_).cwiseMin(upper_);
                const Eigen::Matrix<double, 6, 1> candidateError = poseError(chainFk(chain, candidate), target);
                const double candidateCost = candidateError.squaredNorm();
                if (candidateCost < cost)
                {
                    q = candidate;
                    error = candidateError;
                    cost = candidateCost;
                    lambda = std::max(lambda * 0.1, 1e-12);
                }
                else
                {
                    lambda *= 10.0;
                    if (lambda > 1e4)
                        break;  // stuck at a joint limit or a local minimum: restart
                }
            }
            if (converged(error))
            {
                solution = q;
                return true;
            }
        }
        return false;
    }

}  // namespace slideplan
