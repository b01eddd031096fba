// circdrive: the HAL adapter, and the only file of the module that calls HAL or RTAPI.
// `count=N` instances circdrive.0 .. circdrive.N-1, each with its pins and one function of its
// own name; the function reads each pin once, runs the kernel and writes the outputs.
extern "C" {
#include "hal.h"
#include "rtapi.h"
#include "rtapi_app.h"
}

#include <new>

#include "circdrive_kernel.hpp"
#include "hal_instances.hpp"

namespace drive = circtest::drive;
namespace hal_adapter = circtest::hal_adapter;

extern "C" {
MODULE_AUTHOR("circtest");
MODULE_DESCRIPTION(
    "circdrive: simulated velocity-mode servo drive with motor lag, Coulomb friction and "
    "stiction");
MODULE_LICENSE("GPL");

static int count = 0;
RTAPI_MP_INT(count, "number of instances circdrive.0 .. circdrive.N-1, 1..8");

int rtapi_app_main(void);
void rtapi_app_exit(void);
}

namespace {

struct Instance {
  hal_float_t* vel_cmd;
  hal_bit_t* enable;
  hal_float_t* tau;
  hal_float_t* integral_time;
  hal_float_t* coulomb;
  hal_float_t* breakaway;
  hal_float_t* pos;
  hal_float_t* vel;
  hal_float_t* effort;
  hal_float_t* friction;
  hal_bit_t* stuck;
  hal_u32_t* breakaways;
  hal_u32_t* rejected;
  drive::Drive model;
};

int comp_id = -1;

void update(void* arg, long period) {
  auto* inst = static_cast<Instance*>(arg);
  drive::Params p;
  p.enable = *inst->enable;
  p.tau_s = *inst->tau;
  p.ti_s = *inst->integral_time;
  p.coulomb = *inst->coulomb;
  p.breakaway = *inst->breakaway;
  *inst->pos = inst->model.step(*inst->vel_cmd, static_cast<double>(period) * 1e-9, p);
  *inst->vel = inst->model.velocity();
  *inst->effort = inst->model.effort();
  *inst->friction = inst->model.friction();
  *inst->stuck = inst->model.stuck();
  *inst->breakaways = inst->model.breakaways();
  *inst->rejected = inst->model.rejected();
}

int export_instance(Instance* inst, const char* name) {
  const drive::Params d;  // the kernel's defaults are the pins' start values
  int r = hal_adapter::float_pin(comp_id, HAL_IN, &inst->vel_cmd, name, "vel-cmd", 0.0);
  if (r == 0) r = hal_pin_bit_newf(HAL_IN, &inst->enable, comp_id, "%s.enable", name);
  if (r == 0) r = hal_adapter::float_pin(comp_id, HAL_IN, &inst->tau, name, "tau", d.tau_s);
  if (r == 0)
    r = hal_adapter::float_pin(comp_id, HAL_IN, &inst->integral_time, name, "integral-time",
                               d.ti_s);
  if (r == 0)
    r = hal_adapter::float_pin(comp_id, HAL_IN, &inst->coulomb, name, "coulomb", d.coulomb);
  if (r == 0)
    r = hal_adapter::float_pin(comp_id, HAL_IN, &inst->breakaway, name, "breakaway", d.breakaway);
  if (r == 0) r = hal_adapter::float_pin(comp_id, HAL_OUT, &inst->pos, name, "pos", 0.0);
  if (r == 0) r = hal_adapter::float_pin(comp_id, HAL_OUT, &inst->vel, name, "vel", 0.0);
  if (r == 0) r = hal_adapter::float_pin(comp_id, HAL_OUT, &inst->effort, name, "effort", 0.0);
  if (r == 0) r = hal_adapter::float_pin(comp_id, HAL_OUT, &inst->friction, name, "friction", 0.0);
  if (r == 0) r = hal_pin_bit_newf(HAL_OUT, &inst->stuck, comp_id, "%s.stuck", name);
  if (r == 0) r = hal_pin_u32_newf(HAL_OUT, &inst->breakaways, comp_id, "%s.breakaways", name);
  if (r == 0) r = hal_pin_u32_newf(HAL_OUT, &inst->rejected, comp_id, "%s.rejected", name);
  if (r != 0) return r;
  *inst->enable = d.enable;
  *inst->stuck = 1;
  *inst->breakaways = 0;
  *inst->rejected = 0;
  return hal_export_funct(name, update, inst, 1, 0, comp_id);
}

}  // namespace

int rtapi_app_main(void) {
  if (count < 1 || count > drive::kMaxInstances) {
    rtapi_print_msg(RTAPI_MSG_ERR,
                    "circdrive: count=%d: give count=N with N in 1..%d (one drive per joint)\n",
                    count, drive::kMaxInstances);
    return -EINVAL;
  }
  comp_id = hal_init("circdrive");
  if (comp_id < 0) return comp_id;
  return hal_adapter::export_instances<Instance>(
      comp_id, "circdrive", count,
      [](int i, char* name, unsigned long size) { rtapi_snprintf(name, size, "circdrive.%d", i); },
      export_instance);
}

void rtapi_app_exit(void) {
  hal_exit(comp_id);
}
