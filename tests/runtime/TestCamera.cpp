// The double-precision camera: orientation conventions, projection, culling and screen error.
#include <gtest/gtest.h>

#include <glm/geometric.hpp>

#include "pbdam/runtime/Camera.h"

using namespace pbdam::runtime;

namespace pbdam::runtime {
namespace {

TEST(Camera, DefaultPoseLooksStraightDownWithNorthUp) {
  const Planet mars = Planet::mars();
  const Camera c = Camera::fromPose(mars, {0.0, 0.0, 1000.0}, Viewport{});
  EXPECT_NEAR(glm::length(c.position()), 3396190.0 + 1000.0, 1e-6);
  EXPECT_NEAR(c.forward().x, -1.0, 1e-12);  // (0°, 0°) is +X; down is −X
  EXPECT_NEAR(c.up().z, 1.0, 1e-12);        // north is +Z
  EXPECT_NEAR(c.right().y, 1.0, 1e-12);     // east is +Y
}

TEST(Camera, HeadingPitchRollFollowTheEnuConvention) {
  const Planet mars = Planet::mars();
  // Heading 90 (east), level: forward is east (+Y at 0°, 0°), up is local up (+X).
  const Camera c = Camera::fromPose(mars, {0.0, 0.0, 1000.0, 90.0, 0.0, 0.0}, Viewport{});
  EXPECT_NEAR(c.forward().y, 1.0, 1e-12);
  EXPECT_NEAR(c.up().x, 1.0, 1e-12);
  // Roll 90 clockwise: the right axis turns down.
  const Camera r = Camera::fromPose(mars, {0.0, 0.0, 1000.0, 90.0, 0.0, 90.0}, Viewport{});
  EXPECT_NEAR(r.right().x, -1.0, 1e-12);
}

TEST(Camera, ReversedZProjectionAndScreenError) {
  Camera c(glm::dvec3(0.0), {1, 0, 0}, {0, 1, 0}, {0, 0, -1}, Viewport{1280, 720, 90.0});
  c.setNearMeters(0.5);
  const glm::mat4 p = c.projection();
  const glm::vec4 nearPoint = p * glm::vec4(0.0f, 0.0f, -0.5f, 1.0f);
  EXPECT_FLOAT_EQ(nearPoint.z / nearPoint.w, 1.0f);
  const glm::vec4 far = p * glm::vec4(0.0f, 0.0f, -1e9f, 1.0f);
  EXPECT_LT(far.z / far.w, 1e-9f);
  // fov 90°: 360 px per unit of size/distance.
  EXPECT_DOUBLE_EQ(c.pixelsPerRadian(), 360.0);
  EXPECT_NEAR(c.screenError(1.0, {0, 0, -110.0}, 10.0), 3.6, 1e-12);
  EXPECT_TRUE(std::isinf(c.screenError(1.0, {0, 0, -5.0}, 10.0)));
  EXPECT_TRUE(c.sphereInFrustum({0, 0, -100}, 1.0));
  EXPECT_FALSE(c.sphereInFrustum({0, 0, 100}, 1.0));      // behind
  EXPECT_FALSE(c.sphereInFrustum({200, 0, -100}, 1.0));   // right of the 90° frustum
  EXPECT_TRUE(c.sphereInFrustum({200, 0, -100}, 100.0));  // large enough to reach into it
}

TEST(Camera, ParsesAndValidatesPoses) {
  const auto pose = parseCameraPose("10,20,300");
  ASSERT_TRUE(pose.ok());
  EXPECT_EQ(pose->pitchDegrees, -90.0);
  const auto full = parseCameraPose("10,20,300,45,-30,5");
  ASSERT_TRUE(full.ok());
  EXPECT_EQ(full->rollDegrees, 5.0);
  for (const char* bad : {"", "1,2", "1,2,3,4", "a,b,c", "1,2,nan", "1,2,3,4,5,6,7"}) {
    EXPECT_FALSE(parseCameraPose(bad).ok()) << bad;
  }
  const Planet mars = Planet::mars();
  EXPECT_FALSE(validateCameraPose({91.0, 0.0, 10.0}, mars).ok());
  EXPECT_FALSE(validateCameraPose({0.0, 0.0, -2e6}, mars).ok());
  EXPECT_FALSE(validateCameraPose({0.0, 0.0, 10.0, 0.0, -100.0, 0.0}, mars).ok());
  EXPECT_TRUE(validateCameraPose({0.0, 0.0, 10.0}, mars).ok());
  EXPECT_FALSE(validateViewport({0, 10, 60.0}).ok());
  EXPECT_FALSE(validateViewport({10, 10, 180.0}).ok());
  EXPECT_TRUE(validateViewport({640, 480, 60.0}).ok());
}

}  // namespace
}  // namespace pbdam::runtime
