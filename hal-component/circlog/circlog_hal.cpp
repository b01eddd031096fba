// circlog: the HAL adapter, and the only file of the module that calls HAL or RTAPI.
// Everything is allocated in rtapi_app_main (HAL memory for pins, an RTAPI shared-memory
// block for the ring); the realtime function only hands pin values to the kernel and
// copies its counters back to pins.
extern "C" {
#include "hal.h"
#include "rtapi.h"
#include "rtapi_app.h"
}

#include <new>

#include "circlog_kernel.hpp"

extern "C" {
MODULE_AUTHOR("circtest");
MODULE_DESCRIPTION("circlog: lossless-or-loud servo-period logger for the circular test");
MODULE_LICENSE("GPL");

static int channels = 0;
RTAPI_MP_INT(channels, "number of float input channels, 1..16 (required)");
static int depth = circtest::circlog::kDefaultDepth;
RTAPI_MP_INT(depth, "records in the ring (default 16384: 16 s at 1 kHz)");

int rtapi_app_main(void);
void rtapi_app_exit(void);
}

namespace {

struct Instance {
  hal_float_t* in[circtest::circlog::kMaxChannels];
  hal_bit_t* enable;
  hal_float_t* segment;
  hal_u32_t* written;
  hal_u32_t* overruns;
  hal_u32_t* high_water;
  hal_bit_t* reading;
  hal_u32_t channels_param;
  hal_u32_t depth_param;
  circtest::circlog::Producer producer;
};

int comp_id = -1;
int shmem_id = -1;

// HAL pins are 32 bits wide in 2.9; the records carry the full 64-bit counters.
std::uint32_t low32(std::uint64_t v) {
  return static_cast<std::uint32_t>(v & 0xffffffffu);
}

void sample(void* arg, long period) {
  auto* inst = static_cast<Instance*>(arg);
  inst->producer.step(*inst->enable, *inst->segment, inst->in, period);
  const circtest::circlog::Status s = inst->producer.status();
  *inst->written = low32(s.written);
  *inst->overruns = low32(s.overruns);
  *inst->high_water = low32(s.high_water);
  *inst->reading = s.reader_attached;
}

int export_pins(Instance* inst) {
  int r = 0;
  for (int i = 0; i < channels && r == 0; ++i) {
    r = hal_pin_float_newf(HAL_IN, &inst->in[i], comp_id, "circlog.0.in-%02d", i);
  }
  if (r == 0) r = hal_pin_bit_newf(HAL_IN, &inst->enable, comp_id, "circlog.0.enable");
  if (r == 0) r = hal_pin_float_newf(HAL_IN, &inst->segment, comp_id, "circlog.0.segment");
  if (r == 0) r = hal_pin_u32_newf(HAL_OUT, &inst->written, comp_id, "circlog.0.written");
  if (r == 0) r = hal_pin_u32_newf(HAL_OUT, &inst->overruns, comp_id, "circlog.0.overruns");
  if (r == 0) r = hal_pin_u32_newf(HAL_OUT, &inst->high_water, comp_id, "circlog.0.high-water");
  if (r == 0) r = hal_pin_bit_newf(HAL_OUT, &inst->reading, comp_id, "circlog.0.reading");
  if (r == 0) {
    r = hal_param_u32_newf(HAL_RO, &inst->channels_param, comp_id, "circlog.0.channels");
  }
  if (r == 0) r = hal_param_u32_newf(HAL_RO, &inst->depth_param, comp_id, "circlog.0.depth");
  return r;
}

int fail(const char* message, int code) {
  rtapi_print_msg(RTAPI_MSG_ERR, "circlog: %s\n", message);
  if (shmem_id >= 0) rtapi_shmem_delete(shmem_id, comp_id);
  shmem_id = -1;
  hal_exit(comp_id);
  return code;
}

}  // namespace

int rtapi_app_main(void) {
  if (channels < 1 || channels > circtest::circlog::kMaxChannels) {
    rtapi_print_msg(RTAPI_MSG_ERR, "circlog: channels=%d: give channels=N with N in 1..%d\n",
                    channels, circtest::circlog::kMaxChannels);
    return -EINVAL;
  }
  if (depth < circtest::circlog::kMinDepth || depth > circtest::circlog::kMaxDepth) {
    rtapi_print_msg(RTAPI_MSG_ERR, "circlog: depth=%d: give depth=K with K in %d..%d\n", depth,
                    circtest::circlog::kMinDepth, circtest::circlog::kMaxDepth);
    return -EINVAL;
  }
  comp_id = hal_init("circlog");
  if (comp_id < 0) return comp_id;

  const std::size_t bytes = circtest::circlog::shared_size(channels, depth);
  shmem_id = rtapi_shmem_new(circtest::circlog::kShmKeyBase, comp_id, bytes);
  if (shmem_id < 0) {
    // shmget refuses a size larger than an existing segment's: a recorder that outlived
    // an earlier circlog with a smaller ring still holds it.
    rtapi_print_msg(RTAPI_MSG_ERR,
                    "circlog: cannot create the %lu-byte ring (key 0x%08x); if an old "
                    "circlog-record is still running stop it, else remove the segment with "
                    "'ipcrm -M 0x%08x'\n",
                    static_cast<unsigned long>(bytes), circtest::circlog::kShmKeyBase,
                    circtest::circlog::kShmKeyBase);
    const int code = shmem_id;
    shmem_id = -1;
    return fail("ring allocation failed", code);
  }
  void* memory = nullptr;
  if (rtapi_shmem_getptr(shmem_id, &memory) < 0) return fail("rtapi_shmem_getptr failed", -EINVAL);

  void* raw = hal_malloc(sizeof(Instance));
  if (raw == nullptr) return fail("hal_malloc failed", -ENOMEM);
  auto* inst = new (raw) Instance{};
  if (!inst->producer.init(memory, bytes, channels, depth)) {
    return fail("the ring does not fit its shared block", -EINVAL);
  }
  int r = export_pins(inst);
  if (r != 0) return fail("exporting pins failed", r);
  inst->channels_param = static_cast<std::uint32_t>(channels);
  inst->depth_param = static_cast<std::uint32_t>(depth);

  r = hal_export_funct("circlog.0", sample, inst, 1, 0, comp_id);
  if (r != 0) return fail("exporting function circlog.0 failed", r);

  rtapi_print_msg(RTAPI_MSG_INFO, "circlog: %d channels, ring of %d records (%lu bytes)\n",
                  channels, depth, static_cast<unsigned long>(bytes));
  hal_ready(comp_id);
  return 0;
}

void rtapi_app_exit(void) {
  if (shmem_id >= 0) rtapi_shmem_delete(shmem_id, comp_id);
  shmem_id = -1;
  hal_exit(comp_id);
}
