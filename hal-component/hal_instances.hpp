#pragma once
// Load-time set-up shared by the HAL adapters of circtest's realtime components (circfric,
// circdrive): one float pin with its start value, and the instances allocated in HAL memory
// and exported one after the other, as pid.c does. Runs in rtapi_app_main only, never in a
// component's realtime function.
#include <new>

#include "hal.h"
#include "rtapi.h"

namespace circtest::hal_adapter {

// COMPONENT.SUFFIX-style pin "NAME.SUFFIX", set to VALUE once created.
inline int float_pin(int comp_id, hal_pin_dir_t dir, hal_float_t** pin, const char* name,
                     const char* suffix, double value) {
  const int r = hal_pin_float_newf(dir, pin, comp_id, "%s.%s", name, suffix);
  if (r == 0) **pin = value;
  return r;
}

// HOW_MANY instances of Instance, named by NAME_AT(i, buffer, size), each exported by
// EXPORT_ONE(instance, name); on a failure the component is unloaded again (hal_exit) and the
// error returned, otherwise it is made ready.
template <class Instance, class NameAt, class ExportOne>
int export_instances(int comp_id, const char* component, int how_many, NameAt name_at,
                     ExportOne export_one) {
  for (int i = 0; i < how_many; ++i) {
    char name[HAL_NAME_LEN + 1];
    name_at(i, name, sizeof name);
    void* raw = hal_malloc(sizeof(Instance));
    const int r = raw == nullptr ? -ENOMEM : export_one(new (raw) Instance{}, name);
    if (r != 0) {
      rtapi_print_msg(RTAPI_MSG_ERR, "%s: exporting the pins and function of %s failed\n",
                      component, name);
      hal_exit(comp_id);
      return r;
    }
  }
  rtapi_print_msg(RTAPI_MSG_INFO, "%s: %d instance(s)\n", component, how_many);
  hal_ready(comp_id);
  return 0;
}

}  // namespace circtest::hal_adapter
