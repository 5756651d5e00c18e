// Vulkan plumbing of the GPU backend (vk.hpp).
#include "gpu/vk.hpp"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <cstring>

#include "dofkit/error.hpp"
#include "gpu/spirv.hpp"

namespace dofkit::gpu {

namespace {
std::atomic<int> g_validation{-1};  // -1: from the environment (DOFKIT_VK_VALIDATION)
std::atomic<int> g_drop_barrier{-1};
}  // namespace

void set_validation(bool on) { g_validation.store(on ? 1 : 0); }
bool validation_enabled() {
  const int v = g_validation.load();
  if (v >= 0) return v != 0;
  const char* e = std::getenv("DOFKIT_VK_VALIDATION");
  return e && std::strcmp(e, "0") != 0 && *e;
}
namespace testing {
void drop_barrier(int index) { g_drop_barrier.store(index); }
}  // namespace testing

namespace vk {

namespace {

const char* result_name(VkResult r) {
  switch (r) {
    case VK_ERROR_OUT_OF_HOST_MEMORY:
      return "VK_ERROR_OUT_OF_HOST_MEMORY";
    case VK_ERROR_OUT_OF_DEVICE_MEMORY:
      return "VK_ERROR_OUT_OF_DEVICE_MEMORY";
    case VK_ERROR_INITIALIZATION_FAILED:
      return "VK_ERROR_INITIALIZATION_FAILED";
    case VK_ERROR_DEVICE_LOST:
      return "VK_ERROR_DEVICE_LOST";
    case VK_ERROR_LAYER_NOT_PRESENT:
      return "VK_ERROR_LAYER_NOT_PRESENT";
    case VK_ERROR_EXTENSION_NOT_PRESENT:
      return "VK_ERROR_EXTENSION_NOT_PRESENT";
    case VK_ERROR_INCOMPATIBLE_DRIVER:
      return "VK_ERROR_INCOMPATIBLE_DRIVER";
    case VK_ERROR_FEATURE_NOT_PRESENT:
      return "VK_ERROR_FEATURE_NOT_PRESENT";
    default:
      return "VkResult error";
  }
}

std::string version_text(std::uint32_t v) {
  return std::to_string(VK_API_VERSION_MAJOR(v)) + "." + std::to_string(VK_API_VERSION_MINOR(v)) + "." +
         std::to_string(VK_API_VERSION_PATCH(v));
}

VKAPI_ATTR VkBool32 VKAPI_CALL on_message(VkDebugUtilsMessageSeverityFlagBitsEXT, VkDebugUtilsMessageTypeFlagsEXT,
                                          const VkDebugUtilsMessengerCallbackDataEXT* data, void* user) {
  std::string m = data && data->pMessage ? data->pMessage : "(no text)";
  std::replace(m.begin(), m.end(), '\n', ' ');
  static_cast<Context*>(user)->add_message(std::move(m));
  return VK_FALSE;
}

bool has_layer(const char* name) {
  std::uint32_t n = 0;
  vkEnumerateInstanceLayerProperties(&n, nullptr);
  std::vector<VkLayerProperties> layers(n);
  vkEnumerateInstanceLayerProperties(&n, layers.data());
  return std::any_of(layers.begin(), layers.end(),
                     [&](const VkLayerProperties& l) { return std::strcmp(l.layerName, name) == 0; });
}

int type_rank(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return 0;
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return 1;
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return 2;
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return 4;
    default:
      return 3;
  }
}
const char* type_name(VkPhysicalDeviceType t) {
  switch (t) {
    case VK_PHYSICAL_DEVICE_TYPE_DISCRETE_GPU:
      return "discrete";
    case VK_PHYSICAL_DEVICE_TYPE_INTEGRATED_GPU:
      return "integrated";
    case VK_PHYSICAL_DEVICE_TYPE_VIRTUAL_GPU:
      return "virtual";
    case VK_PHYSICAL_DEVICE_TYPE_CPU:
      return "cpu";
    default:
      return "other";
  }
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

std::mutex g_context_mutex;

}  // namespace

void check(VkResult r, const char* what) {
  if (r != VK_SUCCESS) throw_internal(std::string("vulkan: ") + what + " failed (" + result_name(r) + ")");
}

std::shared_ptr<Context> Context::get() {
  // Kept for the process once made; every GPU renderer holds a reference, so it outlives them.
  static std::shared_ptr<Context> ctx;
  std::lock_guard<std::mutex> lock(g_context_mutex);
  if (!ctx) {
    std::shared_ptr<Context> c(new Context());
    c->init();
    ctx = c;
  }
  return ctx;
}

void Context::init() {
  if (volkInitialize() != VK_SUCCESS)
    throw_internal("--backend vulkan: no Vulkan loader on this machine (libvulkan.so.1 not found)");
  validation = validation_enabled();
  std::vector<const char*> layers, extensions;
  if (validation) {
    if (!has_layer("VK_LAYER_KHRONOS_validation"))
      throw_internal(
          "DOFKIT_VK_VALIDATION: the Khronos validation layer is not installed (Debian: vulkan-validationlayers)");
    layers.push_back("VK_LAYER_KHRONOS_validation");
    extensions.push_back(VK_EXT_DEBUG_UTILS_EXTENSION_NAME);
  }
  VkApplicationInfo app{VK_STRUCTURE_TYPE_APPLICATION_INFO};
  app.pApplicationName = "dofkit";
  app.pEngineName = "dofkit";
  app.apiVersion = VK_API_VERSION_1_2;
  // Synchronisation validation: reports read-after-write and write-after-read hazards that a
  // CPU implementation (lavapipe) would never show as wrong numbers.
  const VkValidationFeatureEnableEXT enables[] = {VK_VALIDATION_FEATURE_ENABLE_SYNCHRONIZATION_VALIDATION_EXT};
  VkValidationFeaturesEXT features{VK_STRUCTURE_TYPE_VALIDATION_FEATURES_EXT};
  features.enabledValidationFeatureCount = 1;
  features.pEnabledValidationFeatures = enables;
  VkDebugUtilsMessengerCreateInfoEXT msg{VK_STRUCTURE_TYPE_DEBUG_UTILS_MESSENGER_CREATE_INFO_EXT};
  msg.messageSeverity = VK_DEBUG_UTILS_MESSAGE_SEVERITY_WARNING_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_SEVERITY_ERROR_BIT_EXT;
  msg.messageType = VK_DEBUG_UTILS_MESSAGE_TYPE_GENERAL_BIT_EXT | VK_DEBUG_UTILS_MESSAGE_TYPE_VALIDATION_BIT_EXT |
                    VK_DEBUG_UTILS_MESSAGE_TYPE_PERFORMANCE_BIT_EXT;
  msg.pfnUserCallback = on_message;
  msg.pUserData = this;
  features.pNext = &msg;  // messages from vkCreateInstance itself
  VkInstanceCreateInfo ici{VK_STRUCTURE_TYPE_INSTANCE_CREATE_INFO};
  ici.pNext = validation ? &features : nullptr;
  ici.pApplicationInfo = &app;
  ici.enabledLayerCount = static_cast<std::uint32_t>(layers.size());
  ici.ppEnabledLayerNames = layers.data();
  ici.enabledExtensionCount = static_cast<std::uint32_t>(extensions.size());
  ici.ppEnabledExtensionNames = extensions.data();
  const VkResult r = vkCreateInstance(&ici, nullptr, &instance);
  if (r == VK_ERROR_INCOMPATIBLE_DRIVER) throw_internal("--backend vulkan: no Vulkan device found (no driver)");
  check(r, "vkCreateInstance");
  volkLoadInstanceOnly(instance);
  if (validation) check(vkCreateDebugUtilsMessengerEXT(instance, &msg, nullptr, &messenger_), "debug messenger");

  std::uint32_t n = 0;
  vkEnumeratePhysicalDevices(instance, &n, nullptr);
  std::vector<VkPhysicalDevice> devs(n);
  if (n) vkEnumeratePhysicalDevices(instance, &n, devs.data());
  struct Candidate {
    int index;
    VkPhysicalDevice dev;
    VkPhysicalDeviceProperties props;
    std::uint32_t family;
  };
  std::vector<Candidate> usable;
  std::string listing;
  for (std::uint32_t i = 0; i < n; ++i) {
    VkPhysicalDeviceProperties p;
    vkGetPhysicalDeviceProperties(devs[i], &p);
    std::uint32_t nq = 0;
    vkGetPhysicalDeviceQueueFamilyProperties(devs[i], &nq, nullptr);
    std::vector<VkQueueFamilyProperties> q(nq);
    vkGetPhysicalDeviceQueueFamilyProperties(devs[i], &nq, q.data());
    listing += (listing.empty() ? "" : ", ") + std::to_string(i) + " " + p.deviceName;
    for (std::uint32_t f = 0; f < nq; ++f)
      if ((q[f].queueFlags & VK_QUEUE_COMPUTE_BIT) && q[f].timestampValidBits > 0 &&
          p.apiVersion >= VK_API_VERSION_1_1) {
        usable.push_back({static_cast<int>(i), devs[i], p, f});
        break;
      }
  }
  if (usable.empty())
    throw_internal("--backend vulkan: no Vulkan device with compute queues and timestamps found" +
                   (listing.empty() ? std::string() : " (have: " + listing + ")"));
  const Candidate* pick = nullptr;
  if (const char* want = std::getenv("DOFKIT_VK_DEVICE"); want && *want) {
    const std::string w = want;
    const bool numeric =
        std::all_of(w.begin(), w.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); });
    for (const Candidate& c : usable)
      if (numeric ? std::to_string(c.index) == w : lower(c.props.deviceName).find(lower(w)) != std::string::npos) {
        pick = &c;
        break;
      }
    if (!pick) throw_internal("DOFKIT_VK_DEVICE=" + w + ": no such usable Vulkan device (have: " + listing + ")");
  } else {
    // A discrete GPU first, then integrated, virtual, other; the CPU implementation last.
    pick = &*std::min_element(usable.begin(), usable.end(), [](const Candidate& a, const Candidate& b) {
      return std::make_pair(type_rank(a.props.deviceType), a.index) <
             std::make_pair(type_rank(b.props.deviceType), b.index);
    });
  }
  phys = pick->dev;
  family = pick->family;
  timestamp_ns = pick->props.limits.timestampPeriod;
  ubo_align = std::max<VkDeviceSize>(256, pick->props.limits.minUniformBufferOffsetAlignment);
  max_storage_bytes = pick->props.limits.maxStorageBufferRange;
  std::uint32_t nq = 0;
  vkGetPhysicalDeviceQueueFamilyProperties(phys, &nq, nullptr);
  std::vector<VkQueueFamilyProperties> qf(nq);
  vkGetPhysicalDeviceQueueFamilyProperties(phys, &nq, qf.data());
  const std::uint32_t bits = qf[family].timestampValidBits;
  timestamp_mask = bits >= 64 ? ~0ull : ((1ull << bits) - 1);
  info.index = pick->index;
  info.name = pick->props.deviceName;
  info.type = type_name(pick->props.deviceType);
  info.api = version_text(pick->props.apiVersion);
  VkPhysicalDeviceDriverProperties drv{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_DRIVER_PROPERTIES};
  VkPhysicalDeviceProperties2 p2{VK_STRUCTURE_TYPE_PHYSICAL_DEVICE_PROPERTIES_2};
  if (pick->props.apiVersion >= VK_API_VERSION_1_2) p2.pNext = &drv;
  vkGetPhysicalDeviceProperties2(phys, &p2);
  info.driver = p2.pNext ? std::string(drv.driverName) + " " + drv.driverInfo
                         : "driver version " + std::to_string(pick->props.driverVersion);

  const float priority = 1.0f;
  VkDeviceQueueCreateInfo qci{VK_STRUCTURE_TYPE_DEVICE_QUEUE_CREATE_INFO};
  qci.queueFamilyIndex = family;
  qci.queueCount = 1;
  qci.pQueuePriorities = &priority;
  VkPhysicalDeviceFeatures have{}, want{};
  vkGetPhysicalDeviceFeatures(phys, &have);
  want.shaderFloat64 = have.shaderFloat64;  // starcraft's depth path (docs/gpu.md)
  float64 = have.shaderFloat64 == VK_TRUE;
  VkDeviceCreateInfo dci{VK_STRUCTURE_TYPE_DEVICE_CREATE_INFO};
  dci.queueCreateInfoCount = 1;
  dci.pQueueCreateInfos = &qci;
  dci.pEnabledFeatures = &want;
  check(vkCreateDevice(phys, &dci, nullptr, &device), "vkCreateDevice");
  volkLoadDevice(device);
  vkGetDeviceQueue(device, family, 0, &queue);
}

Context::~Context() {
  if (device) {
    vkDeviceWaitIdle(device);
    for (auto& [name, m] : modules_) vkDestroyShaderModule(device, m, nullptr);
    vkDestroyDevice(device, nullptr);
  }
  if (messenger_) vkDestroyDebugUtilsMessengerEXT(instance, messenger_, nullptr);
  if (instance) vkDestroyInstance(instance, nullptr);
}

std::uint32_t Context::memory_type(std::uint32_t bits, VkMemoryPropertyFlags need, VkMemoryPropertyFlags prefer) const {
  VkPhysicalDeviceMemoryProperties mp;
  vkGetPhysicalDeviceMemoryProperties(phys, &mp);
  for (const VkMemoryPropertyFlags want : {need | prefer, need})
    for (std::uint32_t i = 0; i < mp.memoryTypeCount; ++i)
      if ((bits & (1u << i)) && (mp.memoryTypes[i].propertyFlags & want) == want) return i;
  throw_internal("vulkan: no suitable memory type");
}

Buffer Context::make_buffer(VkDeviceSize bytes, VkBufferUsageFlags usage, bool host_visible) {
  Buffer b;
  b.size = std::max<VkDeviceSize>(bytes, 16);
  VkBufferCreateInfo bci{VK_STRUCTURE_TYPE_BUFFER_CREATE_INFO};
  bci.size = b.size;
  bci.usage = usage;
  bci.sharingMode = VK_SHARING_MODE_EXCLUSIVE;
  check(vkCreateBuffer(device, &bci, nullptr, &b.buf), "vkCreateBuffer");
  VkMemoryRequirements req;
  vkGetBufferMemoryRequirements(device, b.buf, &req);
  VkMemoryAllocateInfo mai{VK_STRUCTURE_TYPE_MEMORY_ALLOCATE_INFO};
  mai.allocationSize = req.size;
  mai.memoryTypeIndex =
      host_visible
          ? memory_type(req.memoryTypeBits, VK_MEMORY_PROPERTY_HOST_VISIBLE_BIT | VK_MEMORY_PROPERTY_HOST_COHERENT_BIT,
                        VK_MEMORY_PROPERTY_HOST_CACHED_BIT)
          : memory_type(req.memoryTypeBits, 0, VK_MEMORY_PROPERTY_DEVICE_LOCAL_BIT);
  const VkResult r = vkAllocateMemory(device, &mai, nullptr, &b.mem);
  if (r != VK_SUCCESS) {
    vkDestroyBuffer(device, b.buf, nullptr);
    check(r, "vkAllocateMemory");
  }
  vkBindBufferMemory(device, b.buf, b.mem, 0);
  if (host_visible) check(vkMapMemory(device, b.mem, 0, VK_WHOLE_SIZE, 0, &b.map), "vkMapMemory");
  std::lock_guard<std::mutex> lock(mutex_);
  b.generation = ++generation_;
  return b;
}

void Context::destroy(Buffer& b) {
  if (b.buf) vkDestroyBuffer(device, b.buf, nullptr);
  if (b.mem) vkFreeMemory(device, b.mem, nullptr);
  b = Buffer{};
}

VkShaderModule Context::module(const std::string& name) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = modules_.find(name);
  if (it != modules_.end()) return it->second;
  const SpirvModule* spv = find_spirv(name.c_str());
  if (!spv) throw_internal("vulkan: no embedded shader " + name);
  VkShaderModuleCreateInfo ci{VK_STRUCTURE_TYPE_SHADER_MODULE_CREATE_INFO};
  ci.codeSize = spv->count * sizeof(std::uint32_t);
  ci.pCode = spv->words;
  VkShaderModule m;
  check(vkCreateShaderModule(device, &ci, nullptr, &m), "vkCreateShaderModule");
  modules_[name] = m;
  return m;
}

void Context::submit_and_wait(VkCommandBuffer cmd, VkFence fence) {
  VkSubmitInfo si{VK_STRUCTURE_TYPE_SUBMIT_INFO};
  si.commandBufferCount = 1;
  si.pCommandBuffers = &cmd;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    check(vkQueueSubmit(queue, 1, &si, fence), "vkQueueSubmit");
  }
  check(vkWaitForFences(device, 1, &fence, VK_TRUE, UINT64_MAX), "vkWaitForFences");
  check(vkResetFences(device, 1, &fence), "vkResetFences");
}

std::vector<std::string> Context::take_messages() {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> out;
  out.swap(messages_);
  return out;
}

void Context::add_message(std::string m) {
  std::lock_guard<std::mutex> lock(mutex_);
  messages_.push_back(std::move(m));
}

// ---------------------------------------------------------------------------------------
// Graph

namespace {
constexpr std::uint32_t kMaxSlots = 128;   // dispatches per frame
constexpr std::uint32_t kMaxBuffers = 12;  // storage buffers per dispatch
constexpr std::uint32_t kMaxQueries = 256;
constexpr std::size_t kParamsBytes = 256;
}  // namespace

Graph::Graph(std::shared_ptr<Context> ctx) : ctx_(std::move(ctx)) {
  VkDevice d = ctx_->device;
  VkDescriptorPoolSize sizes[2] = {{VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER, kMaxSlots},
                                   {VK_DESCRIPTOR_TYPE_STORAGE_BUFFER, kMaxSlots * kMaxBuffers}};
  VkDescriptorPoolCreateInfo dp{VK_STRUCTURE_TYPE_DESCRIPTOR_POOL_CREATE_INFO};
  dp.maxSets = kMaxSlots;
  dp.poolSizeCount = 2;
  dp.pPoolSizes = sizes;
  check(vkCreateDescriptorPool(d, &dp, nullptr, &pool_), "vkCreateDescriptorPool");
  VkCommandPoolCreateInfo cp{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  cp.flags = VK_COMMAND_POOL_CREATE_RESET_COMMAND_BUFFER_BIT;
  cp.queueFamilyIndex = ctx_->family;
  check(vkCreateCommandPool(d, &cp, nullptr, &cmd_pool_), "vkCreateCommandPool");
  VkCommandBufferAllocateInfo ca{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ca.commandPool = cmd_pool_;
  ca.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ca.commandBufferCount = 1;
  check(vkAllocateCommandBuffers(d, &ca, &cmd_), "vkAllocateCommandBuffers");
  VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
  check(vkCreateFence(d, &fi, nullptr, &fence_), "vkCreateFence");
  VkQueryPoolCreateInfo qp{VK_STRUCTURE_TYPE_QUERY_POOL_CREATE_INFO};
  qp.queryType = VK_QUERY_TYPE_TIMESTAMP;
  qp.queryCount = kMaxQueries;
  check(vkCreateQueryPool(d, &qp, nullptr, &queries_), "vkCreateQueryPool");
  ubo_ = ctx_->make_buffer(kMaxSlots * std::max<VkDeviceSize>(kParamsBytes, ctx_->ubo_align),
                           VK_BUFFER_USAGE_UNIFORM_BUFFER_BIT, true);
}

Graph::~Graph() {
  VkDevice d = ctx_->device;
  vkDeviceWaitIdle(d);
  for (Buffer& b : buffers_) ctx_->destroy(b);
  ctx_->destroy(ubo_);
  ctx_->destroy(upload_);
  ctx_->destroy(readback_);
  for (auto& [name, p] : pipelines_) {
    vkDestroyPipeline(d, p.pipe, nullptr);
    vkDestroyPipelineLayout(d, p.layout, nullptr);
  }
  for (auto& [n, l] : set_layouts_) vkDestroyDescriptorSetLayout(d, l, nullptr);
  vkDestroyDescriptorPool(d, pool_, nullptr);
  vkDestroyQueryPool(d, queries_, nullptr);
  vkDestroyFence(d, fence_, nullptr);
  vkDestroyCommandPool(d, cmd_pool_, nullptr);
}

int Graph::buffer(const std::string& name, std::size_t floats) {
  const VkDeviceSize bytes = std::max<VkDeviceSize>(floats, 1) * sizeof(float);
  if (bytes > ctx_->max_storage_bytes)
    throw_internal("--backend vulkan: the frame needs a " + std::to_string(bytes >> 20) + " MiB buffer (" + name +
                   "), more than this device binds (" + std::to_string(ctx_->max_storage_bytes >> 20) + " MiB)");
  auto it = buffer_ids_.find(name);
  if (it != buffer_ids_.end()) {
    Buffer& b = buffers_[it->second];
    if (b.size != std::max<VkDeviceSize>(bytes, 16)) {
      // Only between frames (end_frame waited for the device).
      ctx_->destroy(b);
      b = ctx_->make_buffer(
          bytes,
          VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
          false);
    }
    return it->second;
  }
  buffers_.push_back(ctx_->make_buffer(
      bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
      false));
  buffer_ids_[name] = static_cast<int>(buffers_.size()) - 1;
  return static_cast<int>(buffers_.size()) - 1;
}

VkDescriptorSetLayout Graph::set_layout(int nbuf) {
  auto it = set_layouts_.find(nbuf);
  if (it != set_layouts_.end()) return it->second;
  std::vector<VkDescriptorSetLayoutBinding> b(nbuf + 1);
  for (int i = 0; i <= nbuf; ++i) {
    b[i].binding = i;
    b[i].descriptorType = i == 0 ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
    b[i].descriptorCount = 1;
    b[i].stageFlags = VK_SHADER_STAGE_COMPUTE_BIT;
  }
  VkDescriptorSetLayoutCreateInfo ci{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_LAYOUT_CREATE_INFO};
  ci.bindingCount = static_cast<std::uint32_t>(b.size());
  ci.pBindings = b.data();
  VkDescriptorSetLayout l;
  check(vkCreateDescriptorSetLayout(ctx_->device, &ci, nullptr, &l), "vkCreateDescriptorSetLayout");
  set_layouts_[nbuf] = l;
  return l;
}

Graph::Pipeline& Graph::pipeline(const char* shader, int nbuf) {
  auto it = pipelines_.find(shader);
  if (it != pipelines_.end()) {
    if (it->second.nbuf != nbuf)
      throw_internal(std::string("vulkan: shader ") + shader + " bound with another buffer count");
    return it->second;
  }
  Pipeline p;
  p.nbuf = nbuf;
  VkDescriptorSetLayout l = set_layout(nbuf);
  VkPipelineLayoutCreateInfo pl{VK_STRUCTURE_TYPE_PIPELINE_LAYOUT_CREATE_INFO};
  pl.setLayoutCount = 1;
  pl.pSetLayouts = &l;
  check(vkCreatePipelineLayout(ctx_->device, &pl, nullptr, &p.layout), "vkCreatePipelineLayout");
  VkComputePipelineCreateInfo ci{VK_STRUCTURE_TYPE_COMPUTE_PIPELINE_CREATE_INFO};
  ci.stage.sType = VK_STRUCTURE_TYPE_PIPELINE_SHADER_STAGE_CREATE_INFO;
  ci.stage.stage = VK_SHADER_STAGE_COMPUTE_BIT;
  ci.stage.module = ctx_->module(shader);
  ci.stage.pName = "main";
  ci.layout = p.layout;
  check(vkCreateComputePipelines(ctx_->device, VK_NULL_HANDLE, 1, &ci, nullptr, &p.pipe), "vkCreateComputePipelines");
  return pipelines_[shader] = p;
}

void Graph::timestamp() {
  if (query_count_ >= kMaxQueries) throw_internal("vulkan: too many passes in one frame");
  vkCmdWriteTimestamp(cmd_, VK_PIPELINE_STAGE_BOTTOM_OF_PIPE_BIT, queries_, query_count_++);
}

void Graph::barrier(VkPipelineStageFlags src, VkAccessFlags src_access, VkPipelineStageFlags dst,
                    VkAccessFlags dst_access) {
  VkMemoryBarrier b{VK_STRUCTURE_TYPE_MEMORY_BARRIER};
  b.srcAccessMask = src_access;
  b.dstAccessMask = dst_access;
  vkCmdPipelineBarrier(cmd_, src, dst, 0, 1, &b, 0, nullptr, 0, nullptr);
}

void Graph::begin_frame(std::size_t upload_floats, std::size_t readback_floats) {
  // Room for each transfer's 256-byte alignment: at most 16 transfers of each kind per frame.
  staging(upload_, (upload_floats + 16 * 64) * sizeof(float), false);
  staging(readback_, (readback_floats + 16 * 64) * sizeof(float), true);
  check(vkResetCommandBuffer(cmd_, 0), "vkResetCommandBuffer");
  VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
  bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
  check(vkBeginCommandBuffer(cmd_, &bi), "vkBeginCommandBuffer");
  vkCmdResetQueryPool(cmd_, queries_, 0, kMaxQueries);
  query_count_ = 0;
  upload_used_ = readback_used_ = 0;
  downloads_.clear();
  marks_.clear();
  current_pass_.clear();
  dispatch_index_ = 0;
  after_upload_ = false;
  downloading_ = false;
  // Everything of the previous frame (its shader and transfer writes) before anything of this one.
  barrier(VK_PIPELINE_STAGE_ALL_COMMANDS_BIT, VK_ACCESS_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_ALL_COMMANDS_BIT,
          VK_ACCESS_MEMORY_READ_BIT | VK_ACCESS_MEMORY_WRITE_BIT);
  timestamp();  // query 0: start of the uploads
}

Buffer& Graph::staging(Buffer& b, std::size_t bytes, bool readback) {
  if (b.size < bytes) {
    // Only between frames (begin_frame): no recorded command refers to the old buffer.
    if (b.buf) ctx_->destroy(b);
    b = ctx_->make_buffer(bytes * 5 / 4, readback ? VK_BUFFER_USAGE_TRANSFER_DST_BIT : VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                          true);
  }
  return b;
}

void Graph::upload(int id, const float* const* planes, int n, std::size_t plane_floats) {
  const std::size_t bytes = static_cast<std::size_t>(n) * plane_floats * sizeof(float);
  if (upload_used_ + bytes > upload_.size) throw_internal("vulkan: upload staging too small (internal)");
  char* dst = static_cast<char*>(upload_.map) + upload_used_;
  for (int c = 0; c < n; ++c)
    std::memcpy(dst + c * plane_floats * sizeof(float), planes[c], plane_floats * sizeof(float));
  VkBufferCopy region{upload_used_, 0, bytes};
  vkCmdCopyBuffer(cmd_, upload_.buf, buffers_[id].buf, 1, &region);
  upload_used_ += (bytes + 255) / 256 * 256;
}

void Graph::dispatch(const char* shader, const std::vector<int>& bufs, const void* params, std::size_t params_size,
                     std::uint32_t gx, std::uint32_t gy, const std::string& pass) {
  if (params_size > kParamsBytes) throw_internal("vulkan: shader parameters too large");
  if (bufs.size() > kMaxBuffers) throw_internal("vulkan: too many buffers for one dispatch");
  if (static_cast<std::uint32_t>(dispatch_index_) >= kMaxSlots)
    throw_internal("vulkan: too many dispatches in a frame");
  Pipeline& p = pipeline(shader, static_cast<int>(bufs.size()));
  if (!after_upload_) {
    timestamp();  // query 1: end of the uploads, start of the passes
    passes_begin_ = query_count_ - 1;
    after_upload_ = true;
  }
  if (pass != current_pass_) {
    if (!current_pass_.empty()) timestamp();
    marks_.push_back({pass, query_count_ - 1});
    current_pass_ = pass;
  }
  // The barrier in front of every dispatch: earlier shader writes and the uploads happen
  // before this dispatch reads or writes (testing::drop_barrier leaves one out).
  if (g_drop_barrier.load() != dispatch_index_)
    barrier(VK_PIPELINE_STAGE_TRANSFER_BIT | VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
            VK_ACCESS_TRANSFER_WRITE_BIT | VK_ACCESS_SHADER_WRITE_BIT, VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT,
            VK_ACCESS_SHADER_READ_BIT | VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_UNIFORM_READ_BIT);
  const VkDeviceSize stride = std::max<VkDeviceSize>(kParamsBytes, ctx_->ubo_align);
  const VkDeviceSize ubo_offset = stride * dispatch_index_;
  std::memcpy(static_cast<char*>(ubo_.map) + ubo_offset, params, params_size);
  if (slots_.size() <= static_cast<std::size_t>(dispatch_index_)) slots_.resize(dispatch_index_ + 1);
  Slot& s = slots_[dispatch_index_];
  std::vector<std::uint64_t> gens;
  for (int b : bufs) gens.push_back(buffers_[b].generation);
  if (s.set == VK_NULL_HANDLE || s.shader != shader || s.generations != gens) {
    if (s.set == VK_NULL_HANDLE || s.shader != shader) {
      // A slot keeps one set; a different shader (another buffer count) needs a new one.
      if (s.set != VK_NULL_HANDLE && pipelines_[s.shader].nbuf != p.nbuf)
        throw_internal("vulkan: dispatch order changed between frames (internal)");
      if (s.set == VK_NULL_HANDLE) {
        VkDescriptorSetLayout l = set_layout(p.nbuf);
        VkDescriptorSetAllocateInfo ai{VK_STRUCTURE_TYPE_DESCRIPTOR_SET_ALLOCATE_INFO};
        ai.descriptorPool = pool_;
        ai.descriptorSetCount = 1;
        ai.pSetLayouts = &l;
        check(vkAllocateDescriptorSets(ctx_->device, &ai, &s.set), "vkAllocateDescriptorSets");
      }
    }
    std::vector<VkDescriptorBufferInfo> infos(bufs.size() + 1);
    std::vector<VkWriteDescriptorSet> writes(bufs.size() + 1);
    infos[0] = {ubo_.buf, ubo_offset, kParamsBytes};
    for (std::size_t i = 0; i < bufs.size(); ++i) infos[i + 1] = {buffers_[bufs[i]].buf, 0, VK_WHOLE_SIZE};
    for (std::size_t i = 0; i < infos.size(); ++i) {
      writes[i] = VkWriteDescriptorSet{VK_STRUCTURE_TYPE_WRITE_DESCRIPTOR_SET};
      writes[i].dstSet = s.set;
      writes[i].dstBinding = static_cast<std::uint32_t>(i);
      writes[i].descriptorCount = 1;
      writes[i].descriptorType = i == 0 ? VK_DESCRIPTOR_TYPE_UNIFORM_BUFFER : VK_DESCRIPTOR_TYPE_STORAGE_BUFFER;
      writes[i].pBufferInfo = &infos[i];
    }
    vkUpdateDescriptorSets(ctx_->device, static_cast<std::uint32_t>(writes.size()), writes.data(), 0, nullptr);
    s.shader = shader;
    s.generations = gens;
  }
  vkCmdBindPipeline(cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, p.pipe);
  vkCmdBindDescriptorSets(cmd_, VK_PIPELINE_BIND_POINT_COMPUTE, p.layout, 0, 1, &s.set, 0, nullptr);
  vkCmdDispatch(cmd_, std::max(gx, 1u), std::max(gy, 1u), 1);
  ++dispatch_index_;
}

void Graph::download(int id, std::size_t offset, std::size_t floats, float* dst) {
  if (!downloading_) {
    if (after_upload_) {
      timestamp();  // end of the last pass
    } else {
      timestamp();
      passes_begin_ = query_count_ - 1;
      after_upload_ = true;
    }
    passes_end_ = query_count_ - 1;
    barrier(VK_PIPELINE_STAGE_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_TRANSFER_BIT,
            VK_ACCESS_SHADER_WRITE_BIT | VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_TRANSFER_BIT,
            VK_ACCESS_TRANSFER_READ_BIT);
    downloading_ = true;
  }
  const std::size_t bytes = floats * sizeof(float);
  if (readback_used_ + bytes > readback_.size) throw_internal("vulkan: readback staging too small (internal)");
  VkBufferCopy region{offset * sizeof(float), readback_used_, bytes};
  vkCmdCopyBuffer(cmd_, buffers_[id].buf, readback_.buf, 1, &region);
  downloads_.push_back({readback_used_, floats, dst});
  readback_used_ += (bytes + 255) / 256 * 256;
}

void Graph::end_frame() {
  if (!downloading_) throw_internal("vulkan: a frame with no download (internal)");
  barrier(VK_PIPELINE_STAGE_TRANSFER_BIT, VK_ACCESS_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_HOST_BIT,
          VK_ACCESS_HOST_READ_BIT);
  timestamp();
  check(vkEndCommandBuffer(cmd_), "vkEndCommandBuffer");
  ctx_->submit_and_wait(cmd_, fence_);
  for (const Download& d : downloads_)
    std::memcpy(d.dst, static_cast<const char*>(readback_.map) + d.staging_offset, d.floats * sizeof(float));
  std::vector<std::uint64_t> ts(query_count_);
  check(vkGetQueryPoolResults(ctx_->device, queries_, 0, query_count_, ts.size() * sizeof(std::uint64_t), ts.data(),
                              sizeof(std::uint64_t), VK_QUERY_RESULT_64_BIT | VK_QUERY_RESULT_WAIT_BIT),
        "vkGetQueryPoolResults");
  auto ms = [&](std::uint32_t a, std::uint32_t b) {
    return static_cast<double>((ts[b] - ts[a]) & ctx_->timestamp_mask) * ctx_->timestamp_ns * 1e-6;
  };
  times_ = FrameTimes{};
  times_.upload_ms = ms(0, passes_begin_);
  times_.passes_ms = ms(passes_begin_, passes_end_);
  times_.download_ms = ms(passes_end_, query_count_ - 1);
  for (std::size_t i = 0; i < marks_.size(); ++i) {
    const std::uint32_t end = i + 1 < marks_.size() ? marks_[i + 1].second : passes_end_;
    // A pass name used twice in a frame adds up.
    auto it = std::find_if(times_.passes.begin(), times_.passes.end(),
                           [&](const FrameTimes::Pass& p) { return p.name == marks_[i].first; });
    if (it == times_.passes.end()) it = times_.passes.insert(times_.passes.end(), {marks_[i].first, 0.0});
    it->ms += ms(marks_[i].second, end);
  }
  if (ctx_->validation) {
    const std::vector<std::string> m = ctx_->take_messages();
    if (!m.empty())
      throw_internal("vulkan validation: " + m.front() +
                     (m.size() > 1 ? " (and " + std::to_string(m.size() - 1) + " more)" : std::string()));
  }
}

}  // namespace vk
}  // namespace dofkit::gpu
