// Vulkan plumbing of the GPU backend: the process-wide device (Context) and the per-renderer
// command recorder (Graph) that keeps buffers, pipelines and descriptor sets from frame to
// frame. Only src/gpu/ includes this header.
#pragma once
#include <volk.h>

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "gpu/gpu.hpp"

namespace dofkit::gpu::vk {

/// Throws Error(internal) "vulkan: <what> failed (VK_ERROR_...)" unless r is VK_SUCCESS.
void check(VkResult r, const char* what);

/// A buffer and its memory; `map` is set for host-visible buffers (persistently mapped).
struct Buffer {
  VkBuffer buf = VK_NULL_HANDLE;
  VkDeviceMemory mem = VK_NULL_HANDLE;
  VkDeviceSize size = 0;
  void* map = nullptr;
  std::uint64_t generation = 0;  ///< unique per allocation (handles may be reused after a free)
};

/// The instance, the chosen device and its compute queue; one per process, shared by every
/// GPU renderer (Context::get). Thread-safe where noted.
class Context {
 public:
  /// Created on first use; throws Error(internal) with a one-line reason when there is no
  /// loader, no device, or DOFKIT_VK_DEVICE names none.
  static std::shared_ptr<Context> get();
  ~Context();

  VkInstance instance = VK_NULL_HANDLE;
  VkPhysicalDevice phys = VK_NULL_HANDLE;
  VkDevice device = VK_NULL_HANDLE;
  VkQueue queue = VK_NULL_HANDLE;
  std::uint32_t family = 0;
  DeviceInfo info;
  double timestamp_ns = 1;  ///< ns per timestamp tick
  std::uint64_t timestamp_mask = ~0ull;
  VkDeviceSize ubo_align = 256;
  bool validation = false;
  bool float64 = false;                ///< shaderFloat64 (enabled when the device has it)
  VkDeviceSize max_storage_bytes = 0;  ///< maxStorageBufferRange

  Buffer make_buffer(VkDeviceSize bytes, VkBufferUsageFlags usage, bool host_visible);
  void destroy(Buffer& b);
  /// The shader module of an embedded SPIR-V module (cached; thread-safe).
  VkShaderModule module(const std::string& name);
  /// Submits one command buffer and waits for it (thread-safe).
  void submit_and_wait(VkCommandBuffer cmd, VkFence fence);
  /// Validation messages received since the last call (thread-safe).
  std::vector<std::string> take_messages();
  void add_message(std::string m);

 private:
  Context() = default;
  void init();
  std::uint32_t memory_type(std::uint32_t bits, VkMemoryPropertyFlags need, VkMemoryPropertyFlags prefer) const;
  VkDebugUtilsMessengerEXT messenger_ = VK_NULL_HANDLE;
  std::mutex mutex_;  // modules_, queue, messages_
  std::map<std::string, VkShaderModule> modules_;
  std::vector<std::string> messages_;
  std::uint64_t generation_ = 0;
};

/// Records one frame of dispatches at a time. Buffers are named and kept (re-created only when
/// their size changes); pipelines are made once per shader; each dispatch slot keeps its
/// descriptor set and rewrites it only when its buffers changed. Between dispatches a
/// compute→compute barrier (transfer→compute after the uploads).
class Graph {
 public:
  explicit Graph(std::shared_ptr<Context> ctx);
  ~Graph();
  Graph(const Graph&) = delete;
  Graph& operator=(const Graph&) = delete;

  Context& context() { return *ctx_; }

  /// A device buffer of `floats` 32-bit words (id for dispatch / upload / download).
  int buffer(const std::string& name, std::size_t floats);

  /// Starts recording a frame that uploads at most `upload_floats` and downloads at most
  /// `readback_floats` words (the staging buffers grow to that before anything is recorded).
  void begin_frame(std::size_t upload_floats, std::size_t readback_floats);
  /// Copies n planes of `plane_floats` floats each into buffer `id` (planar, in order).
  void upload(int id, const float* const* planes, int n, std::size_t plane_floats);
  /// Shader `shader` (a module name, e.g. "mcguire/horizontal") over groups_x × groups_y
  /// workgroups; binding 0 = `params` (a uniform block, at most 256 bytes), 1.. = `buffers`.
  /// `pass` names the pass for the timings (consecutive dispatches of one pass share it).
  void dispatch(const char* shader, const std::vector<int>& buffers, const void* params, std::size_t params_size,
                std::uint32_t groups_x, std::uint32_t groups_y, const std::string& pass);
  /// Copies `floats` words at word offset `offset` of buffer `id` to dst after the frame.
  void download(int id, std::size_t offset, std::size_t floats, float* dst);
  /// Submits the frame, waits, copies the downloads out, reads the timestamps. Throws
  /// Error(internal) if validation is on and a message arrived.
  void end_frame();

  const FrameTimes& times() const { return times_; }

 private:
  struct Pipeline {
    VkPipeline pipe = VK_NULL_HANDLE;
    VkPipelineLayout layout = VK_NULL_HANDLE;
    int nbuf = 0;
  };
  struct Slot {
    std::string shader;
    VkDescriptorSet set = VK_NULL_HANDLE;
    std::vector<std::uint64_t> generations;
  };
  struct Download {
    std::size_t staging_offset;
    std::size_t floats;
    float* dst;
  };
  Pipeline& pipeline(const char* shader, int nbuf);
  VkDescriptorSetLayout set_layout(int nbuf);
  void timestamp();
  void barrier(VkPipelineStageFlags src, VkAccessFlags src_access, VkPipelineStageFlags dst, VkAccessFlags dst_access);
  Buffer& staging(Buffer& b, std::size_t bytes, bool readback);

  std::shared_ptr<Context> ctx_;
  std::vector<Buffer> buffers_;
  std::map<std::string, int> buffer_ids_;
  std::map<int, VkDescriptorSetLayout> set_layouts_;
  std::map<std::string, Pipeline> pipelines_;
  std::vector<Slot> slots_;
  VkDescriptorPool pool_ = VK_NULL_HANDLE;
  VkCommandPool cmd_pool_ = VK_NULL_HANDLE;
  VkCommandBuffer cmd_ = VK_NULL_HANDLE;
  VkFence fence_ = VK_NULL_HANDLE;
  VkQueryPool queries_ = VK_NULL_HANDLE;
  Buffer ubo_, upload_, readback_;
  std::size_t upload_used_ = 0, readback_used_ = 0;
  std::vector<Download> downloads_;
  int dispatch_index_ = 0;
  bool after_upload_ = false, downloading_ = false;
  std::uint32_t query_count_ = 0;
  std::vector<std::pair<std::string, std::uint32_t>> marks_;  // pass name, query index of its start
  std::string current_pass_;
  std::uint32_t passes_begin_ = 0, passes_end_ = 0;
  FrameTimes times_;
};

}  // namespace dofkit::gpu::vk
