#include "serve_rate.h"

#include <nlohmann/json.hpp>

#include "igtl_wire.h"
#include "lamina/core/error.h"
#include "lamina/core/log.h"
#include "lamina/interact/rate_choice.h"

namespace lamina::net {

ServeRate::ServeRate(double rate_hz, bool follow_machine)
    : base_hz_(follow_machine ? interact::kRateLadder.front() : rate_hz),
      follow_machine_(follow_machine),
      rate_hz_(base_hz_) {}

const char* ServeRate::chosen_by() const {
  return client_ >= 0 ? "client" : follow_machine_ ? "machine" : "--rate";
}

std::optional<double> ServeRate::change_to(double hz) {
  if (hz == rate_hz_) return std::nullopt;
  rate_hz_ = hz;
  return hz;
}

std::optional<double> ServeRate::ask(int client, const std::string& peer, const std::string& text) {
  if (text == "auto") {
    if (client != client_) return std::nullopt;  // it holds no rate to give back
    client_ = -1;
    log::info("OpenIGTLink client {} gives the rate back ({})", peer,
              follow_machine_ ? "the machine's" : "--rate's");
    return change_to(base_hz_);
  }
  double hz = 0.0;
  try {
    size_t used = 0;
    hz = std::stod(text, &used);
    if (used != text.size()) hz = 0.0;
  } catch (const std::exception&) {
    hz = 0.0;
  }
  if (!(hz > 0.0 && hz <= 1e5))
    throw invalid_input("STRING 'LaminaRate'",
                        "'" + text + "' is not a rate in (0, 100000] Hz or 'auto'");
  if (client_ < 0) base_hz_ = rate_hz_;  // where the machine's (or --rate's) rate comes back to
  client_ = client;
  log::info(
      "OpenIGTLink client {} asks for {:g} steps/s (dt {:.3g} ms): kept while it is connected",
      peer, hz, 1000.0 / hz);
  return change_to(hz);
}

std::optional<double> ServeRate::gone(int client) {
  if (client != client_) return std::nullopt;
  client_ = -1;
  log::info("the client that asked for {:g} steps/s has gone: back to {}", rate_hz_,
            follow_machine_ ? "the rate the machine keeps" : "--rate");
  return change_to(base_hz_);
}

std::optional<double> ServeRate::follow(const interact::RateWindow& snap) {
  if (!follow_machine_ || client_ >= 0) return std::nullopt;
  const std::optional<double> next =
      interact::rate_to_follow(rate_hz_, snap, "--rate or a client's LaminaRate");
  if (!next) return std::nullopt;
  base_hz_ = *next;
  return change_to(*next);
}

std::string ServeRate::status(const interact::RateWindow& snap) const {
  nlohmann::json j;
  j["rate_hz"] = rate_hz_;
  j["chosen_by"] = chosen_by();
  // A rate just set has no second measured yet: only what it is and who chose it.
  if (snap.measured_rate_hz != rate_hz_) return j.dump();
  j["keeping_up"] = snap.keeping_up;
  j["real_time_factor"] = snap.real_time_factor;
  j["step_ms"] = snap.mean_step_us / 1000.0;
  if (!snap.keeping_up) j["keeps_up_hz"] = interact::next_rate(rate_hz_, snap.mean_step_us, false);
  return j.dump();
}

ServeRate::Judgement ServeRate::judge(const interact::RateWindow& w, uint64_t second) {
  Judgement j;
  if (second == last_second_) return j;
  last_second_ = second;
  const double asked_hz = rate_hz_;  // what the second just measured was asked to keep
  j.new_rate = follow(w);
  j.tell = j.new_rate || (w.measured_rate_hz == rate_hz_ && (!w.keeping_up || behind_));
  // A second measured at another rate than the one asked for says nothing of it.
  if (w.measured_rate_hz != asked_hz) return j;
  if (!w.keeping_up) {
    behind_s_ += 1.0;
    // (The machine's rate moving down has said so itself.)
    if (!j.new_rate && (!behind_ || ServeClock::now() >= next_behind_warning_)) {
      log::warn(
          "behind real time: {:.2f} simulated seconds per wall second ({:.0f} of {:.0f} "
          "steps/s, {:.0f} us a step); a lower --rate, a smaller model or, on a busy machine, "
          "--threads 1 keeps up",
          w.real_time_factor, w.achieved_rate_hz, rate_hz_, w.mean_step_us);
      next_behind_warning_ = ServeClock::now() + std::chrono::seconds(10);
    }
  } else if (behind_) {
    log::info("back in real time ({:.2f} simulated seconds per wall second)", w.real_time_factor);
  }
  behind_ = !w.keeping_up;
  return j;
}

void send_rate_status(igtlink::Server& server, const ServeRate& rate, int client, bool streaming,
                      const interact::RateWindow& measured) {
  const igtlink::Packed status = igtlink::pack_string("LaminaRealTime", rate.status(measured));
  if (client >= 0)
    server.send(client, status);
  else if (streaming)
    server.broadcast(status);
  else if (rate.client() >= 0)
    server.send(rate.client(), status);
}

}  // namespace lamina::net
