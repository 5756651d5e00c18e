// The GPU backend's entry points (gpu.hpp): method → renderer, device choice, frame-copy timing.
#include <algorithm>

#include "dofkit/error.hpp"
#include "gpu/gpu.hpp"
#include "gpu/methods/common.hpp"
#include "gpu/vk.hpp"

namespace dofkit::gpu {

std::vector<std::string> supported_methods() { return {"mcguire", "starcraft", "sterna"}; }

std::unique_ptr<MethodRenderer> make_renderer(const RenderSettings& settings) {
  const std::vector<std::string> names = supported_methods();
  if (std::find(names.begin(), names.end(), settings.method) == names.end())
    throw_usage("--backend vulkan: method " + settings.method +
                " has no GPU shaders (the vulkan backend runs mcguire, starcraft, sterna)");
  if (!settings.debug_view.empty())
    throw_usage("--debug-view " + settings.debug_view + ": debug views are not available with --backend vulkan");
  if (settings.method == "mcguire") return make_mcguire(settings);
  if (settings.method == "sterna") return make_sterna(settings);
  return make_starcraft(settings);
}

DeviceInfo selected_device() { return vk::Context::get()->info; }

std::vector<double> time_frame_copy(int width, int height, bool half, int iterations) {
  std::shared_ptr<vk::Context> ctx = vk::Context::get();
  VkDevice d = ctx->device;
  const VkFormat format = half ? VK_FORMAT_R16G16B16A16_SFLOAT : VK_FORMAT_R32G32B32A32_SFLOAT;
  struct Img {
    VkImage image = VK_NULL_HANDLE;
    VkDeviceMemory mem = VK_NULL_HANDLE;
  } img[2];
  VkCommandPool pool = VK_NULL_HANDLE;
  VkQueryPool queries = VK_NULL_HANDLE;
  VkFence fence = VK_NULL_HANDLE;
  const std::uint32_t nq = 2 * static_cast<std::uint32_t>(iterations + 1);
  auto cleanup = [&] {
    vkDeviceWaitIdle(d);
    for (Img& i : img) {
      if (i.image) vkDestroyImage(d, i.image, nullptr);
      if (i.mem) vkFreeMemory(d, i.mem, nullptr);
    }
    if (pool) vkDestroyCommandPool(d, pool, nullptr);
    if (queries) vkDestroyQueryPool(d, queries, nullptr);
    if (fence) vkDestroyFence(d, fence, nullptr);
  };
  std::vector<double> out;
  try {
    VkPhysicalDeviceMemoryProperties mp;
    vkGetPhysicalDeviceMemoryProperties(ctx->phys, &mp);
    for (Img& i : img) {
      VkImageCreateInfo ci{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
      ci.imageType = VK_IMAGE_TYPE_2D;
      ci.format = format;
      ci.extent = {static_cast<std::uint32_t>(width), static_cast<std::uint32_t>(height), 1};
      ci.mipLevels = 1;
      ci.arrayLayers = 1;
      ci.samples = VK_SAMPLE_COUNT_1_BIT;
      ci.tiling = VK_IMAGE_TILING_OPTIMAL;
      ci.usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
      ci.initialLayout = VK_IMAGE_LAYOUT_UNDEFINED;
      vk::check(vkCreateImage(d, &ci, nullptr, &i.image), "vkCreateImage");
      VkMemoryRequirements req;
      vkGetImageMemoryRequirements(d, i.image, &req);
      std::uint32_t type = UINT32_MAX;
      for (std::uint32_t t = 0; t < mp.memoryTypeCount && type == UINT32_MAX; ++t)
        if ((req.memoryTypeBits & (1u << t)) && (mp.memoryTypes[t].propertyFlags & VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT))
          type = t;
      for (std::uint32_t t = 0; t < mp.memoryTypeCount && type == UINT32_MAX; ++t)
        if (req.memoryTypeBits & (1u << t)) type = t;
      VkMemoryAllocateInfo ai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
      ai.allocationSize = req.size;
      ai.memoryTypeIndex = type;
      vk::check(vkAllocateMemory(d, &ai, nullptr, &i.mem), "vkAllocateMemory");
      vk::check(vkBindImageMemory(d, i.image, i.mem, 0), "vkBindImageMemory");
    }
    VkCommandPoolCreateInfo cp{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
    cp.queueFamilyIndex = ctx->family;
    vk::check(vkCreateCommandPool(d, &cp, nullptr, &pool), "vkCreateCommandPool");
    VkCommandBufferAllocateInfo ca{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
    ca.commandPool = pool;
    ca.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
    ca.commandBufferCount = 1;
    VkCommandBuffer cmd;
    vk::check(vkAllocateCommandBuffers(d, &ca, &cmd), "vkAllocateCommandBuffers");
    VkQueryPoolCreateInfo qp{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
    qp.queryType = VK_QUERY_TYPE_TIMESTAMP;
    qp.queryCount = nq;
    vk::check(vkCreateQueryPool(d, &qp, nullptr, &queries), "vkCreateQueryPool");
    VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    vk::check(vkCreateFence(d, &fi, nullptr, &fence), "vkCreateFence");

    VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    vk::check(vkBeginCommandBuffer(cmd, &bi), "vkBeginCommandBuffer");
    vkCmdResetQueryPool(cmd, queries, 0, nq);
    VkImageMemoryBarrier to[2];
    for (int i = 0; i < 2; ++i) {
      to[i] = VkImageMemoryBarrier{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER};
      to[i].srcAccessMask = 0;
      to[i].dstAccessMask = i == 0 ? VK_ACCESS_TRANSFER_READ_BIT : VK_ACCESS_TRANSFER_WRITE_BIT;
      to[i].oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
      to[i].newLayout = i == 0 ? VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL : VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
      to[i].srcQueueFamilyIndex = to[i].dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
      to[i].image = img[i].image;
      to[i].subresourceRange = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    }
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TOP_OF_PIPE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0,
                         nullptr, 2, to);
    // The source's contents do not matter for the time; clear it so nothing reads undefined data.
    const VkClearColorValue zero{};
    const VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    VkImageMemoryBarrier src_clear = to[0];
    src_clear.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    src_clear.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    src_clear.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    src_clear.srcAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr,
                         1, &src_clear);
    vkCmdClearColorImage(cmd, img[0].image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &zero, 1, &range);
    VkImageMemoryBarrier back = src_clear;
    back.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
    back.dstAccessMask = VK_ACCESS_TRANSFER_READ_BIT;
    back.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    back.newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
    vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 0, nullptr, 0, nullptr,
                         1, &back);
    VkImageCopy region{};
    region.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.dstSubresource = region.srcSubresource;
    region.extent = {static_cast<std::uint32_t>(width), static_cast<std::uint32_t>(height), 1};
    for (int it = 0; it <= iterations; ++it) {
      // Each copy after the previous one has finished writing (write-after-write on the target).
      VkMemoryBarrier mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
      mb.srcAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
      mb.dstAccessMask = VK_ACCESS_TRANSFER_WRITE_BIT;
      vkCmdPipelineBarrier(cmd, VK_PIPELINE_STAGE_TRANSFER_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT, 0, 1, &mb, 0, nullptr,
                           0, nullptr);
      vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries, 2 * it);
      vkCmdCopyImage(cmd, img[0].image, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, img[1].image,
                     VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
      vkCmdWriteTimestamp(cmd, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries, 2 * it + 1);
    }
    vk::check(vkEndCommandBuffer(cmd), "vkEndCommandBuffer");
    ctx->submit_and_wait(cmd, fence);
    std::vector<std::uint64_t> ts(nq);
    vk::check(vkGetQueryPoolResults(d, queries, 0, nq, ts.size() * sizeof(std::uint64_t), ts.data(),
                                    sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
              "vkGetQueryPoolResults");
    for (int it = 1; it <= iterations; ++it)
      out.push_back(static_cast<double>((ts[2 * it + 1] - ts[2 * it]) & ctx->timestamp_mask) * ctx->timestamp_ns *
                    1e-6);
  } catch (...) {
    cleanup();
    throw;
  }
  cleanup();
  if (ctx->validation) {
    const std::vector<std::string> m = ctx->take_messages();
    if (!m.empty()) throw_internal("vulkan validation: " + m.front());
  }
  return out;
}

}  // namespace dofkit::gpu
