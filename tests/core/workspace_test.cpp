// Workspace's typed scratch planes (methods/method.hpp): each element type has its own storage
// under a key (no plane of one type is ever handed out as another), and a plane keeps its
// allocation from frame to frame while its size does not grow.
#include <gtest/gtest.h>

#include <cstdint>

#include "methods/method.hpp"

using dofkit::detail::Workspace;

TEST(Workspace, TypedPlanesUnderOneKeyAreSeparate) {
  Workspace ws;
  std::uint16_t* codes = ws.plane<std::uint16_t>("k", 100);
  std::uint8_t* bytes = ws.plane<std::uint8_t>("k", 100);
  float* floats = ws.plane<float>("k", 100);
  for (int i = 0; i < 100; ++i) {
    codes[i] = static_cast<std::uint16_t>(1000 + i);
    bytes[i] = static_cast<std::uint8_t>(i);
    floats[i] = 0.5f * static_cast<float>(i);
  }
  // Each type's plane kept its own values: none was written through another type's pointer.
  for (int i = 0; i < 100; ++i) {
    EXPECT_EQ(codes[i], 1000 + i);
    EXPECT_EQ(bytes[i], i);
    EXPECT_EQ(floats[i], 0.5f * static_cast<float>(i));
  }
  // Nor does an image of the same key share storage with them.
  float* img = ws.image("k", 10, 10, 1).plane(0);
  EXPECT_NE(static_cast<void*>(img), static_cast<void*>(floats));
}

TEST(Workspace, PlanesAreReusedAcrossFrames) {
  Workspace ws;
  std::uint32_t* first = ws.plane<std::uint32_t>("spans", 4096);
  first[4095] = 7;
  // The next frame of the same size (or smaller) gets the same allocation back.
  EXPECT_EQ(ws.plane<std::uint32_t>("spans", 4096), first);
  EXPECT_EQ(ws.plane<std::uint32_t>("spans", 1024), first);
  std::uint32_t* grown = ws.plane<std::uint32_t>("spans", 1 << 20);
  grown[(1 << 20) - 1] = 9;  // the whole requested size is addressable
  EXPECT_EQ(grown[(1 << 20) - 1], 9u);
  ws.clear();
  std::uint32_t* fresh = ws.plane<std::uint32_t>("spans", 16);
  fresh[15] = 1;
  EXPECT_EQ(fresh[15], 1u);
}
