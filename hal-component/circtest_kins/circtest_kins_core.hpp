#pragma once
// The HAL-free heart of the circtest_kins kinematics module: trivkins' axis-to-joint mapping
// (the coordinates= letters in joint order, a letter twice for a gantry) plus the squareness
// of the three linear axes, exact in both directions. Nothing here allocates, throws, locks or
// calls the OS, so the same code runs inside the realtime module and in the unit tests.
//
// The machine model is the one circana diagnose fits (docs/diagnosis.md) and the simulated
// mill injects: with joint (slide) positions j, the tool is at
//   x = jx + xy * jy,   y = jy + yz * jz,   z = jz + zx * jx        (angles in rad)
// so a positive xy means +X leans towards +Y (the angle between +X and +Y is 90 deg - xy).
// forward() is that model; inverse() solves it exactly, so commanding a world position moves
// the slides where the skewed machine puts the tool on it: the kinematics applies the inverse
// of the measured error.
namespace circtest::kins {

inline constexpr int kMaxJoints = 16;  // EMCMOT_MAX_JOINTS of LinuxCNC 2.9
inline constexpr int kAxes = 9;        // X Y Z A B C U V W, EmcPose's order
inline constexpr int kMaxCoordinateChars = 32;

// Which axis each joint moves, and the principal (first) joint of each axis.
struct JointMap {
  int joints = 0;                   // letters in coordinates=
  int axis_of_joint[kMaxJoints]{};  // 0..8
  int principal_joint[kAxes]{};     // -1 when the axis has no joint
};

enum class MapError { none, empty, bad_letter, too_many_joints, too_long };

// Parses trivkins' coordinates= (letters XYZABCUVW in either case, blanks skipped, a letter
// repeated for a gantry). On an error, *bad_index is the offending character's index.
MapError parse_coordinates(const char* text, JointMap& map, int* bad_index) noexcept;

struct Squareness {
  double xy = 0.0;  // rad: x += xy * y
  double yz = 0.0;  // rad: y += yz * z
  double zx = 0.0;  // rad: z += zx * x
};

// The angles the map can use: a term whose two axes are not both mapped is dropped (a lathe
// with coordinates=XZ keeps only zx), so forward and inverse stay each other's inverse.
Squareness effective(const Squareness& s, const JointMap& map) noexcept;

// Positions of the nine axes in EmcPose order (x y z a b c u v w).
struct World {
  double axis[kAxes]{};
};

// Joints -> world for the mapped axes (each from its principal joint); unmapped axes keep the
// value WORLD has, as trivkins does.
void forward(const Squareness& s, const JointMap& map, const double* joints, World& world) noexcept;
// World -> every joint (a gantry's joints all get their axis's slide position).
void inverse(const Squareness& s, const JointMap& map, const World& world, double* joints) noexcept;

// The largest |angle| the module accepts (10 mrad: a machine out of square by more needs a
// mechanic, and the model is exact anyway); beyond it, or NaN, forward and inverse use 0.
inline constexpr double kMaxSquarenessRad = 0.01;
// S with every angle that is not finite or beyond kMaxSquarenessRad replaced by 0; *rejected
// is set when one was.
Squareness sanitized(const Squareness& s, bool* rejected) noexcept;

}  // namespace circtest::kins
