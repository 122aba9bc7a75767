// DeferredDestruction (internal to pbdam_gpu): the one place where Vulkan objects that a
// submission may still use are destroyed, once that submission has signalled — as filament's
// driver does. A renderer numbers its submissions (1, 2, …) on its fence; an object it replaces
// (a staging or record buffer that grew, an offscreen target after a resize) is retired with the
// number of the last submission that may read it, and destroyed by collect() once the fence has
// passed that number. So more frames in flight cannot turn a replacement into a use-after-free.
// Thread-safety: none (the render thread that owns the renderer).
#pragma once

#include <cstdint>
#include <deque>
#include <memory>
#include <utility>

namespace pbdam::gpu {

class DeferredDestruction final {
 public:
  DeferredDestruction() = default;
  DeferredDestruction(const DeferredDestruction&) = delete;
  DeferredDestruction& operator=(const DeferredDestruction&) = delete;
  DeferredDestruction(DeferredDestruction&&) noexcept = default;
  DeferredDestruction& operator=(DeferredDestruction&&) noexcept = default;
  /// Destroys what is still queued: the owner must have waited for its submissions first.
  ~DeferredDestruction() = default;

  /// Queues `object` (a move-only RAII owner) until submission `lastUse` has completed.
  /// `lastUse` must not be below the number of an earlier retire() call.
  template <typename T>
  void retire(T object, std::uint64_t lastUse) {
    if constexpr (requires { static_cast<bool>(object); }) {
      if (!static_cast<bool>(object)) return;  // an empty owner: nothing to destroy
    }
    queue_.emplace_back(lastUse, std::make_unique<Held<T>>(std::move(object)));
  }

  /// Destroys every queued object whose last use is ≤ `completed` (the number of the latest
  /// submission known to have signalled). Returns how many were destroyed.
  std::size_t collect(std::uint64_t completed) noexcept {
    std::size_t destroyed = 0;
    while (!queue_.empty() && queue_.front().first <= completed) {
      queue_.pop_front();
      ++destroyed;
    }
    return destroyed;
  }

  /// Objects waiting for their submission.
  std::size_t pending() const noexcept { return queue_.size(); }

 private:
  struct Retired {
    virtual ~Retired() = default;
  };
  template <typename T>
  struct Held final : Retired {
    explicit Held(T o) : object(std::move(o)) {}
    T object;
  };
  std::deque<std::pair<std::uint64_t, std::unique_ptr<Retired>>> queue_;
};

}  // namespace pbdam::gpu
