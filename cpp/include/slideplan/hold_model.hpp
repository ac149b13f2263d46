/// \file hold_model.hpp
/// Beyond the paper (grasp_model): whether the closed hand holds the object up against gravity.
///
/// The side grasp pinches the plate between two pads, one above and one below. Gravity lies along the
/// pads' normal, so the pinch carries the weight by its normal forces; what it can lose is the plate's
/// attitude: gravity's moment about the pinch, m g r with r the horizontal lever from the pinch to the
/// centre of mass, turns the plate out of the pads unless the pressure under them shifts to resist it.
/// Each pad is a soft contact over a finite patch (the soft-finger contact of Xydas & Kao, 1999, whose
/// pressure distribution carries a moment about axes in the contact plane); a pad pressing with force
/// F can move its pressure to the patch's end, so the pair resists at most F l about an axis in the
/// plane, l the patch's length along the lever. The model holds when m g r <= F l. Friction plays no
/// part until the plate has turned, which the model does not follow; grip_force is the effective
/// closing force, calibrated against MuJoCo (docs/results/grasp_model.md).
#pragma once

#include "slideplan/area_centroid.hpp"
#include "slideplan/params.hpp"

#include <Eigen/Core>

namespace slideplan
{
    /// The plate and the pinch the model judges.
    struct HoldEstimate
    {
        double patchArea{0.0};  ///< m^2: the object's material between the pads
        double mass{0.0};      ///< kg: object_density x thickness x area
        double lever{0.0};     ///< m: from the patch's centre to the centre of mass, in the table plane
        double patchLength{0.0};  ///< m: the patch's length along the lever
        double demand{0.0};    ///< N m: gravity's moment about the patch, m g lever
        double capacity{0.0};  ///< N m: what the pads resist, grip_force x patchLength
        bool holds{false};     ///< demand <= capacity over a patch with points
    };

    /// The estimate for a grasp at `grasp` (H_g in the table plane, `beyond` m beyond the table edge)
    /// approaching along -`outward` (the edge's outward normal): the pads are a pad_width x pad_length
    /// rectangle centred on H_g, its length along the approach, and reach no closer to the table than its
    /// edge (the lower pad cannot be under what the table bears). `plate`: the object's material at its
    /// final pose (plateRegion of its points); `com`: its centre of mass there. Parameters: pad_width,
    /// pad_length, grip_force, object_density.
    HoldEstimate estimateHold(const PlateRegion &plate, const Eigen::Vector2d &com, double thickness,
                              const Eigen::Vector2d &grasp, double beyond, const Eigen::Vector2d &outward,
                              const PlannerParams &params);
}  // namespace slideplan
