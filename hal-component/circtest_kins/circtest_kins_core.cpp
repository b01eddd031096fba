#include "circtest_kins_core.hpp"

#include <initializer_list>

namespace circtest::kins {

namespace {

constexpr int kX = 0, kY = 1, kZ = 2;

// 0..8 for X Y Z A B C U V W in either case, -1 for anything else.
int axis_of_letter(char c) noexcept {
  constexpr char kLetters[] = "XYZABCUVW";
  const char upper = c >= 'a' && c <= 'z' ? static_cast<char>(c - 'a' + 'A') : c;
  for (int a = 0; a < kAxes; ++a) {
    if (kLetters[a] == upper) return a;
  }
  return -1;
}

bool mapped(const JointMap& map, int axis) noexcept {
  return map.principal_joint[axis] >= 0;
}

bool usable(double angle) noexcept {
  // NaN fails both comparisons.
  return angle >= -kMaxSquarenessRad && angle <= kMaxSquarenessRad;
}

}  // namespace

MapError parse_coordinates(const char* text, JointMap& map, int* bad_index) noexcept {
  map = JointMap{};
  for (int& j : map.principal_joint) j = -1;
  int n = 0;
  for (int i = 0; text != nullptr && text[i] != '\0'; ++i) {
    if (i >= kMaxCoordinateChars) {
      if (bad_index) *bad_index = i;
      return MapError::too_long;
    }
    if (text[i] == ' ' || text[i] == '\t') continue;
    const int axis = axis_of_letter(text[i]);
    if (axis < 0) {
      if (bad_index) *bad_index = i;
      return MapError::bad_letter;
    }
    if (n >= kMaxJoints) {
      if (bad_index) *bad_index = i;
      return MapError::too_many_joints;
    }
    map.axis_of_joint[n] = axis;
    if (map.principal_joint[axis] < 0) map.principal_joint[axis] = n;
    ++n;
  }
  if (n == 0) {
    if (bad_index) *bad_index = 0;
    return MapError::empty;
  }
  map.joints = n;
  return MapError::none;
}

Squareness effective(const Squareness& s, const JointMap& map) noexcept {
  Squareness e;
  e.xy = mapped(map, kX) && mapped(map, kY) ? s.xy : 0.0;
  e.yz = mapped(map, kY) && mapped(map, kZ) ? s.yz : 0.0;
  e.zx = mapped(map, kZ) && mapped(map, kX) ? s.zx : 0.0;
  return e;
}

Squareness sanitized(const Squareness& s, bool* rejected) noexcept {
  Squareness out = s;
  bool bad = false;
  for (double* a : {&out.xy, &out.yz, &out.zx}) {
    if (!usable(*a)) {
      *a = 0.0;
      bad = true;
    }
  }
  if (rejected) *rejected = bad;
  return out;
}

void forward(const Squareness& s, const JointMap& map, const double* joints,
             World& world) noexcept {
  double slide[kAxes];
  for (int a = 0; a < kAxes; ++a) {
    slide[a] = mapped(map, a) ? joints[map.principal_joint[a]] : 0.0;
  }
  const Squareness e = effective(s, map);
  double tool[kAxes];
  for (int a = 0; a < kAxes; ++a) tool[a] = slide[a];
  tool[kX] += e.xy * slide[kY];
  tool[kY] += e.yz * slide[kZ];
  tool[kZ] += e.zx * slide[kX];
  for (int a = 0; a < kAxes; ++a) {
    if (mapped(map, a)) world.axis[a] = tool[a];
  }
}

void inverse(const Squareness& s, const JointMap& map, const World& world,
             double* joints) noexcept {
  const Squareness e = effective(s, map);
  // The three equations of the model form a cycle x <- y <- z <- x; eliminating around it
  // gives jx (1 + xy yz zx) = x - xy y + xy yz z, then jz and jy follow. An unmapped axis's
  // terms are zero (effective), so its world value never enters.
  const double x = mapped(map, kX) ? world.axis[kX] : 0.0;
  const double y = mapped(map, kY) ? world.axis[kY] : 0.0;
  const double z = mapped(map, kZ) ? world.axis[kZ] : 0.0;
  const double jx = (x - e.xy * y + e.xy * e.yz * z) / (1.0 + e.xy * e.yz * e.zx);
  const double jz = z - e.zx * jx;
  const double jy = y - e.yz * jz;
  double slide[kAxes];
  for (int a = 0; a < kAxes; ++a) slide[a] = world.axis[a];
  slide[kX] = jx;
  slide[kY] = jy;
  slide[kZ] = jz;
  for (int j = 0; j < map.joints; ++j) joints[j] = slide[map.axis_of_joint[j]];
}

}  // namespace circtest::kins
