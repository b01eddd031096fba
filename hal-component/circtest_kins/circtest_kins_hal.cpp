// circtest_kins: the LinuxCNC 2.9 kinematics adapter, and the only file of the module that
// calls HAL or RTAPI. trivkins-compatible (coordinates=, a letter twice for a gantry) plus the
// squareness of X to Y, Y to Z and Z to X as HAL pins (rad), set by the HAL file circcomp
// writes. The pins live in HAL memory allocated at load; the kinematics functions, which
// motion calls every servo period, read each pin once and only do arithmetic.
// posemath.h declares C++ overloads when compiled as C++, so it is read first, outside the C
// block; kinematics.h then finds it included and declares the kinematics API with C linkage.
#include "posemath.h"
extern "C" {
#include "hal.h"
#include "kinematics.h"
#include "rtapi.h"
#include "rtapi_app.h"
}

#include "circtest_kins_core.hpp"

namespace kins = circtest::kins;

extern "C" {
MODULE_AUTHOR("circtest");
MODULE_DESCRIPTION("circtest_kins: trivkins with squareness compensation (circcomp)");
MODULE_LICENSE("GPL");

static char* coordinates = const_cast<char*>("XYZABCUVW");
RTAPI_MP_STRING(coordinates, "axis letters in joint order, as trivkins (default XYZABCUVW)");
// Accepted so that a trivkins line works unchanged; the type is always KINEMATICS_BOTH.
static char* kinstype = const_cast<char*>("both");
RTAPI_MP_STRING(kinstype, "accepted for trivkins compatibility (always both)");

int rtapi_app_main(void);
void rtapi_app_exit(void);

int kinematicsForward(const double* joints, EmcPose* pos, const KINEMATICS_FORWARD_FLAGS* fflags,
                      KINEMATICS_INVERSE_FLAGS* iflags);
int kinematicsInverse(const EmcPose* pos, double* joints, const KINEMATICS_INVERSE_FLAGS* iflags,
                      KINEMATICS_FORWARD_FLAGS* fflags);
KINEMATICS_TYPE kinematicsType(void);
int kinematicsSwitchable(void);
int kinematicsSwitch(int switchkins_type);
}

namespace {

struct Pins {
  hal_float_t* squareness_xy;
  hal_float_t* squareness_yz;
  hal_float_t* squareness_zx;
  hal_bit_t* rejected;  // an angle was NaN or beyond 10 mrad: 0 used instead
};

int comp_id = -1;
Pins* pins = nullptr;
kins::JointMap joint_map;

kins::Squareness read_pins() {
  kins::Squareness s;
  s.xy = *pins->squareness_xy;
  s.yz = *pins->squareness_yz;
  s.zx = *pins->squareness_zx;
  bool rejected = false;
  s = kins::sanitized(s, &rejected);
  *pins->rejected = rejected;
  return s;
}

void to_world(const EmcPose& pos, kins::World& w) {
  w.axis[0] = pos.tran.x;
  w.axis[1] = pos.tran.y;
  w.axis[2] = pos.tran.z;
  w.axis[3] = pos.a;
  w.axis[4] = pos.b;
  w.axis[5] = pos.c;
  w.axis[6] = pos.u;
  w.axis[7] = pos.v;
  w.axis[8] = pos.w;
}

void to_pose(const kins::World& w, EmcPose& pos) {
  pos.tran.x = w.axis[0];
  pos.tran.y = w.axis[1];
  pos.tran.z = w.axis[2];
  pos.a = w.axis[3];
  pos.b = w.axis[4];
  pos.c = w.axis[5];
  pos.u = w.axis[6];
  pos.v = w.axis[7];
  pos.w = w.axis[8];
}

const char* map_error_text(kins::MapError e) {
  switch (e) {
    case kins::MapError::empty:
      return "no axis letter";
    case kins::MapError::bad_letter:
      return "a character that is not one of XYZABCUVW";
    case kins::MapError::too_many_joints:
      return "more than 16 joints";
    case kins::MapError::too_long:
      return "more than 32 characters";
    case kins::MapError::none:
      break;
  }
  return "";
}

}  // namespace

int kinematicsForward(const double* joints, EmcPose* pos, const KINEMATICS_FORWARD_FLAGS*,
                      KINEMATICS_INVERSE_FLAGS*) {
  kins::World w;
  to_world(*pos, w);  // unmapped axes keep their value, as trivkins
  kins::forward(read_pins(), joint_map, joints, w);
  to_pose(w, *pos);
  return 0;
}

int kinematicsInverse(const EmcPose* pos, double* joints, const KINEMATICS_INVERSE_FLAGS*,
                      KINEMATICS_FORWARD_FLAGS*) {
  kins::World w;
  to_world(*pos, w);
  kins::inverse(read_pins(), joint_map, w, joints);
  return 0;
}

// Not the identity once an angle is set: motion must call both directions.
KINEMATICS_TYPE kinematicsType(void) {
  return KINEMATICS_BOTH;
}

int kinematicsSwitchable(void) {
  return 0;
}

int kinematicsSwitch(int) {
  return 0;
}

extern "C" {
EXPORT_SYMBOL(kinematicsType);
EXPORT_SYMBOL(kinematicsForward);
EXPORT_SYMBOL(kinematicsInverse);
EXPORT_SYMBOL(kinematicsSwitchable);
EXPORT_SYMBOL(kinematicsSwitch);
}

int rtapi_app_main(void) {
  int bad = 0;
  const kins::MapError e = kins::parse_coordinates(coordinates, joint_map, &bad);
  if (e != kins::MapError::none) {
    rtapi_print_msg(RTAPI_MSG_ERR, "circtest_kins: coordinates=%s: %s (at character %d)\n",
                    coordinates ? coordinates : "", map_error_text(e), bad + 1);
    return -EINVAL;
  }
  comp_id = hal_init("circtest_kins");
  if (comp_id < 0) return comp_id;
  pins = static_cast<Pins*>(hal_malloc(sizeof(Pins)));
  int r = pins == nullptr ? -ENOMEM : 0;
  if (r == 0) {
    r = hal_pin_float_newf(HAL_IN, &pins->squareness_xy, comp_id, "circtest-kins.squareness-xy");
  }
  if (r == 0) {
    r = hal_pin_float_newf(HAL_IN, &pins->squareness_yz, comp_id, "circtest-kins.squareness-yz");
  }
  if (r == 0) {
    r = hal_pin_float_newf(HAL_IN, &pins->squareness_zx, comp_id, "circtest-kins.squareness-zx");
  }
  if (r == 0) {
    r = hal_pin_bit_newf(HAL_OUT, &pins->rejected, comp_id, "circtest-kins.rejected");
  }
  if (r != 0) {
    rtapi_print_msg(RTAPI_MSG_ERR, "circtest_kins: exporting pins failed\n");
    hal_exit(comp_id);
    return r;
  }
  *pins->squareness_xy = 0.0;
  *pins->squareness_yz = 0.0;
  *pins->squareness_zx = 0.0;
  *pins->rejected = 0;
  hal_ready(comp_id);
  return 0;
}

void rtapi_app_exit(void) {
  hal_exit(comp_id);
}
