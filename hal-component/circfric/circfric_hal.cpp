// circfric: the HAL adapter, and the only file of the module that calls HAL or RTAPI.
// Set up at load time like LinuxCNC's pid: `count=N` instances named circfric.0 ..
// circfric.N-1, or `names=a,b,...` instances with those names; every instance gets its pins
// and one function of its own name. Pins live in HAL memory allocated at load; the function
// reads each pin once, runs the kernel and writes the outputs.
extern "C" {
#include "hal.h"
#include "rtapi.h"
#include "rtapi_app.h"
}

#include <new>

#include "circfric_kernel.hpp"
#include "hal_instances.hpp"

namespace fric = circtest::fric;
namespace hal_adapter = circtest::hal_adapter;

extern "C" {
MODULE_AUTHOR("circtest");
MODULE_DESCRIPTION(
    "circfric: friction (reversal spike) compensation as a decaying position offset");
MODULE_LICENSE("GPL");

static int count = 0;
RTAPI_MP_INT(count, "number of instances circfric.0 .. circfric.N-1, 1..8");
static char* names[fric::kMaxInstances] = {nullptr};
RTAPI_MP_ARRAY_STRING(names, fric::kMaxInstances, "instance names (instead of count=), at most 8");

int rtapi_app_main(void);
void rtapi_app_exit(void);
}

namespace {

// The longest pin suffix, ".amplitude-max" / ".vel-threshold"; a name leaves room for it
// within HAL_NAME_LEN.
constexpr int kLongestSuffix = 14;
constexpr int kMaxNameLength = HAL_NAME_LEN - kLongestSuffix;

struct Instance {
  hal_float_t* vel_cmd;
  hal_bit_t* enable;
  hal_float_t* amplitude;
  hal_float_t* amplitude_max;
  hal_float_t* decay_ms;
  hal_float_t* rise_ms;
  hal_float_t* vel_threshold;
  hal_float_t* min_travel;
  hal_float_t* pos_in;
  hal_float_t* offset;
  hal_float_t* pos_out;
  hal_bit_t* active;
  hal_s32_t* direction;
  hal_u32_t* reversals;
  hal_u32_t* rejected;
  fric::Compensator compensator;
};

int comp_id = -1;

void update(void* arg, long period) {
  auto* inst = static_cast<Instance*>(arg);
  fric::Params p;
  p.enable = *inst->enable;
  p.amplitude = *inst->amplitude;
  p.amplitude_max = *inst->amplitude_max;
  p.decay_ms = *inst->decay_ms;
  p.rise_ms = *inst->rise_ms;
  p.vel_threshold = *inst->vel_threshold;
  p.min_travel = *inst->min_travel;
  const double vel_cmd = *inst->vel_cmd;
  const double offset = inst->compensator.step(vel_cmd, static_cast<double>(period) * 1e-9, p);
  *inst->offset = offset;
  // The position command passed through with the offset added, so that no sum2 (which a
  // configuration may already load under other names) is needed.
  *inst->pos_out = *inst->pos_in + offset;
  *inst->active = inst->compensator.active();
  *inst->direction = inst->compensator.direction();
  *inst->reversals = inst->compensator.reversals();
  *inst->rejected = inst->compensator.rejected();
}

int export_instance(Instance* inst, const char* name) {
  const fric::Params d;  // the kernel's defaults are the pins' start values
  int r = hal_adapter::float_pin(comp_id, HAL_IN, &inst->vel_cmd, name, "vel-cmd", 0.0);
  if (r == 0) r = hal_pin_bit_newf(HAL_IN, &inst->enable, comp_id, "%s.enable", name);
  if (r == 0)
    r = hal_adapter::float_pin(comp_id, HAL_IN, &inst->amplitude, name, "amplitude", d.amplitude);
  if (r == 0)
    r = hal_adapter::float_pin(comp_id, HAL_IN, &inst->amplitude_max, name, "amplitude-max",
                               d.amplitude_max);
  if (r == 0)
    r = hal_adapter::float_pin(comp_id, HAL_IN, &inst->decay_ms, name, "decay-ms", d.decay_ms);
  if (r == 0)
    r = hal_adapter::float_pin(comp_id, HAL_IN, &inst->rise_ms, name, "rise-ms", d.rise_ms);
  if (r == 0)
    r = hal_adapter::float_pin(comp_id, HAL_IN, &inst->vel_threshold, name, "vel-threshold",
                               d.vel_threshold);
  if (r == 0)
    r = hal_adapter::float_pin(comp_id, HAL_IN, &inst->min_travel, name, "min-travel",
                               d.min_travel);
  if (r == 0) r = hal_adapter::float_pin(comp_id, HAL_IN, &inst->pos_in, name, "pos-in", 0.0);
  if (r == 0) r = hal_adapter::float_pin(comp_id, HAL_OUT, &inst->offset, name, "offset", 0.0);
  if (r == 0) r = hal_adapter::float_pin(comp_id, HAL_OUT, &inst->pos_out, name, "pos-out", 0.0);
  if (r == 0) r = hal_pin_bit_newf(HAL_OUT, &inst->active, comp_id, "%s.active", name);
  if (r == 0) r = hal_pin_s32_newf(HAL_OUT, &inst->direction, comp_id, "%s.direction", name);
  if (r == 0) r = hal_pin_u32_newf(HAL_OUT, &inst->reversals, comp_id, "%s.reversals", name);
  if (r == 0) r = hal_pin_u32_newf(HAL_OUT, &inst->rejected, comp_id, "%s.rejected", name);
  if (r != 0) return r;
  *inst->enable = d.enable;
  *inst->active = 0;
  *inst->direction = 0;
  *inst->reversals = 0;
  *inst->rejected = 0;
  return hal_export_funct(name, update, inst, 1, 0, comp_id);
}

bool name_char_ok(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' ||
         c == '-' || c == '.';
}

bool same(const char* a, const char* b) {
  while (*a != '\0' && *a == *b) {
    ++a;
    ++b;
  }
  return *a == *b;
}

// The entries names= gave (rtapi leaves the others null).
int given_names() {
  int n = 0;
  for (int i = 0; i < fric::kMaxInstances; ++i) {
    if (names[i] != nullptr) n = i + 1;
  }
  return n;
}

// Checks the N entries of names=; prints why it refuses.
bool check_names(int n) {
  for (int i = 0; i < n; ++i) {
    const char* name = names[i] != nullptr ? names[i] : "";
    int length = 0;
    for (; name[length] != '\0'; ++length) {
      if (!name_char_ok(name[length]) || length >= kMaxNameLength) break;
    }
    if (length == 0 || name[length] != '\0') {
      rtapi_print_msg(RTAPI_MSG_ERR,
                      "circfric: names=: '%s' (name %d): a name is 1..%d characters of "
                      "A-Z a-z 0-9 _ - .\n",
                      name, i + 1, kMaxNameLength);
      return false;
    }
    for (int j = 0; j < i; ++j) {
      if (same(names[j], name)) {
        rtapi_print_msg(RTAPI_MSG_ERR, "circfric: names=: '%s' is given twice\n", name);
        return false;
      }
    }
  }
  return true;
}

}  // namespace

int rtapi_app_main(void) {
  const int named = given_names();
  const bool by_names = named > 0;
  if (by_names && count != 0) {
    rtapi_print_msg(RTAPI_MSG_ERR, "circfric: give count= or names=, not both\n");
    return -EINVAL;
  }
  const int how_many = by_names ? named : count;
  if (by_names) {
    if (!check_names(named)) return -EINVAL;
  } else if (count < 1 || count > fric::kMaxInstances) {
    rtapi_print_msg(RTAPI_MSG_ERR,
                    "circfric: count=%d: give count=N with N in 1..%d (one instance per "
                    "joint) or names=a,b,... (at most %d)\n",
                    count, fric::kMaxInstances, fric::kMaxInstances);
    return -EINVAL;
  }
  comp_id = hal_init("circfric");
  if (comp_id < 0) return comp_id;
  return hal_adapter::export_instances<Instance>(
      comp_id, "circfric", how_many,
      [by_names](int i, char* name, unsigned long size) {
        if (by_names) {
          rtapi_snprintf(name, size, "%s", names[i]);
        } else {
          rtapi_snprintf(name, size, "circfric.%d", i);
        }
      },
      export_instance);
}

void rtapi_app_exit(void) {
  hal_exit(comp_id);
}
