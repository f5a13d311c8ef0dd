#include "control/loop/loop_thread.hpp"

namespace dualv::control {

LoopThread::LoopThread(const ExecutiveConfig& config, LoopClock& clock, LoopClock* work_clock)
    : executive_(config, clock, work_clock), clock_(clock) {}

LoopThread::~LoopThread() {
  stop();
  if (thread_.joinable()) thread_.join();
}

const RealtimeStatus& LoopThread::launch() {
  thread_ = std::thread([this] { body(); });
  std::unique_lock<std::mutex> lock(mutex_);
  cv_.wait(lock, [this] { return prepared_; });
  return executive_.realtime_status();
}

void LoopThread::go(Executor& executor) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    executor_ = &executor;
    go_ns_ = clock_.now_ns();
  }
  cv_.notify_all();
}

void LoopThread::stop() noexcept {
  executive_.request_stop();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    cancelled_ = true;
  }
  cv_.notify_all();
}

RunReport LoopThread::join() {
  if (thread_.joinable()) thread_.join();
  return report_;
}

void LoopThread::body() {
  executive_.prepare_realtime();  // this thread only: SCHED_FIFO, affinity; mlockall
  Executor* ex = nullptr;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    prepared_ = true;
    cv_.notify_all();
    cv_.wait(lock, [this] { return executor_ != nullptr || cancelled_; });
    ex = executor_;
  }
  if (ex == nullptr) return;
  running_.store(true, std::memory_order_release);
  report_ = executive_.run([&](const CycleInfo& info) noexcept {
    if (info.cycle == 0) first_ns_.store(info.wake_ns);
    return ex->step(info);
  });
  running_.store(false, std::memory_order_release);
}

}  // namespace dualv::control
