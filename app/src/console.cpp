#include "console.hpp"
#include "kumite/app/session.hpp"

#include <algorithm>
#include <cmath>

#include "gl.hpp"
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <imgui.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>

#include <fmt/format.h>

namespace kumite::app {

std::optional<int> glfw_key_code(std::string_view name) {
  if (name.size() == 1 && name[0] >= 'A' && name[0] <= 'Z') return GLFW_KEY_A + (name[0] - 'A');
  if (name.size() == 1 && name[0] >= '0' && name[0] <= '9') return GLFW_KEY_0 + (name[0] - '0');
  if (name.size() >= 2 && name.size() <= 3 && name[0] == 'F' && name[1] >= '1' && name[1] <= '9') {
    const int n = name.size() == 2 ? name[1] - '0' : (name[1] - '0') * 10 + (name[2] - '0');
    if (n >= 1 && n <= 12) return GLFW_KEY_F1 + (n - 1);
  }
  if (name.size() == 4 && name.substr(0, 3) == "KP_" && name[3] >= '0' && name[3] <= '9')
    return GLFW_KEY_KP_0 + (name[3] - '0');
  static const std::pair<std::string_view, int> named[] = {
      {"SPACE", GLFW_KEY_SPACE},     {"ENTER", GLFW_KEY_ENTER},   {"TAB", GLFW_KEY_TAB},
      {"BACKSPACE", GLFW_KEY_BACKSPACE}, {"ESCAPE", GLFW_KEY_ESCAPE}, {"LEFT", GLFW_KEY_LEFT},
      {"RIGHT", GLFW_KEY_RIGHT},     {"UP", GLFW_KEY_UP},         {"DOWN", GLFW_KEY_DOWN},
      {"HOME", GLFW_KEY_HOME},       {"END", GLFW_KEY_END},       {"INSERT", GLFW_KEY_INSERT},
      {"DELETE", GLFW_KEY_DELETE},   {"PAGE_UP", GLFW_KEY_PAGE_UP},
      {"PAGE_DOWN", GLFW_KEY_PAGE_DOWN}, {"COMMA", GLFW_KEY_COMMA}, {"PERIOD", GLFW_KEY_PERIOD},
      {"MINUS", GLFW_KEY_MINUS},     {"SLASH", GLFW_KEY_SLASH},   {"SEMICOLON", GLFW_KEY_SEMICOLON},
  };
  for (auto& [n, code] : named)
    if (n == name) return code;
  return std::nullopt;
}

void handle_key(Installation& inst, int key) {
  for (const auto& k : inst.config().keys) {
    if (glfw_key_code(k.name) != key) continue;
    if (k.action.kind == KeyAction::Kind::quit) {
      inst.quit_key(now());  // armed by the first press, quits at the second
      return;
    }
    if (k.action.kind == KeyAction::Kind::record) {
      inst.record_key();
      return;
    }
    inst.order(k.action.to_order(now()));
    return;
  }
}

Console::Console(GLFWwindow* window, StereoMode mode) : window_(window), mode_(mode) {
  glfwMakeContextCurrent(window_);
  glfwSwapInterval(0);
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini beside the binary
  ImGui::StyleColorsDark();
  ImGui_ImplGlfw_InitForOpenGL(window_, true);
  ImGui_ImplOpenGL3_Init("#version 330 core");
}

Console::~Console() {
  glfwMakeContextCurrent(window_);
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
  glfwDestroyWindow(window_);
}

namespace {

const ImVec4 kRed(1.0f, 0.35f, 0.3f, 1.0f);
const ImVec4 kGreen(0.4f, 0.9f, 0.4f, 1.0f);
const ImVec4 kAmber(1.0f, 0.75f, 0.25f, 1.0f);

std::string key_for(const Installation& inst, const KeyAction& action) {
  for (const auto& k : inst.config().keys)
    if (k.action == action) return k.key;
  return "";
}

void order_button(const Installation& inst, Installation* orders, const char* label, OrderKind order,
                  int character = -1) {
  const KeyAction action{KeyAction::Kind::order, order, character};
  const std::string key = key_for(inst, action);
  const std::string text = key.empty() ? std::string(label) : fmt::format("{} [{}]", label, key);
  ImGui::BeginDisabled(orders == nullptr);
  if (ImGui::Button(text.c_str(), ImVec2(170, 0)) && orders) orders->order(action.to_order(now()));
  ImGui::EndDisabled();
}

ImU32 colour(glm::vec3 c) {
  return IM_COL32(static_cast<int>(c.r * 255), static_cast<int>(c.g * 255),
                  static_cast<int>(c.b * 255), 255);
}

/// The room from above: walls (x, z), the visitor (head, facing), the fighter and target,
/// scaled to fit the space it is given (the room's 6 m x 7 m whole, whatever the window).
void top_view(const Installation& inst, const FrameData& f) {
  const ImVec2 size = ImGui::GetContentRegionAvail();
  const ImVec2 o = ImGui::GetCursorScreenPos();
  ImDrawList* dl = ImGui::GetWindowDrawList();
  dl->AddRectFilled(o, ImVec2(o.x + size.x, o.y + size.y), IM_COL32(18, 20, 26, 255));
  // Room x in [-3, 3] across, z in [-5, 2] down (the front wall at the top), centred.
  const double x0 = -3.0, x1 = 3.0, z0 = -5.0, z1 = 2.0;
  const float s = static_cast<float>(std::min(size.x / (x1 - x0), (size.y - 16) / (z1 - z0)));
  const float ox = o.x + (size.x - static_cast<float>(x1 - x0) * s) / 2, oy = o.y + 16;
  auto at = [&](double x, double z) {
    return ImVec2(ox + static_cast<float>(x - x0) * s, oy + static_cast<float>(z - z0) * s);
  };
  for (double x = -3; x <= 3.01; x += 0.5)
    dl->AddLine(at(x, z0), at(x, z1), IM_COL32(40, 44, 54, 255));
  for (double z = z0; z <= z1 + 0.01; z += 0.5)
    dl->AddLine(at(x0, z), at(x1, z), IM_COL32(40, 44, 54, 255));
  for (const auto& w : inst.walls()) {
    const glm::dvec3 d = w.pb + (w.pc - w.pa);
    dl->AddLine(at(w.pa.x, w.pa.z), at(w.pb.x, w.pb.z), IM_COL32(120, 160, 230, 255), 2.5f);
    dl->AddLine(at(w.pc.x, w.pc.z), at(d.x, d.z), IM_COL32(120, 160, 230, 255), 2.5f);
  }
  // Visitor: eyes' midpoint and facing (head -Z).
  const glm::dvec3 mid = (f.eyes.left + f.eyes.right) * 0.5;
  const glm::dvec3 ahead = f.head.orientation * glm::dvec3(0, 0, -0.35);
  const ImU32 visitor = inst.head_live() ? IM_COL32(90, 230, 120, 255) : IM_COL32(230, 180, 60, 255);
  dl->AddCircleFilled(at(mid.x, mid.z), 7, visitor);
  dl->AddLine(at(mid.x, mid.z), at(mid.x + ahead.x, mid.z + ahead.z), visitor, 2.0f);
  if (f.fighter.present) {
    const auto& r = f.fighter.root;
    const ImU32 c = colour(character_colour(f.fighter.character));
    dl->AddCircleFilled(at(r.x, r.z), 9, c);
    // heading 0 faces +Z (the visitor).
    const double hx = std::sin(f.fighter.heading_rad) * 0.4, hz = std::cos(f.fighter.heading_rad) * 0.4;
    dl->AddLine(at(r.x, r.z), at(r.x + hx, r.z + hz), c, 2.0f);
  }
  for (const auto& item : f.items)
    if (item.colour == kTargetColour) {
      const glm::vec3 p(item.model[3]);
      dl->AddCircle(at(p.x, p.z), 6, IM_COL32(255, 40, 40, 255), 0, 2.0f);
    }
  dl->AddText(ImVec2(o.x + 4, o.y + 1), IM_COL32(180, 180, 190, 255), "top view (front wall up)");
  ImGui::Dummy(size);
}

/// A full-width band with large text: the states a supervisor must not miss.
void banner(const char* id, const std::string& text, ImVec4 background) {
  ImGui::PushStyleColor(ImGuiCol_ChildBg, background);
  ImGui::PushStyleColor(ImGuiCol_Text, ImVec4(1, 1, 1, 1));
  ImGui::BeginChild(id, ImVec2(0, 40), false, ImGuiWindowFlags_NoScrollbar | ImGuiWindowFlags_NoScrollWithMouse);
  ImGui::SetWindowFontScale(2.0f);
  ImGui::SetCursorPos(ImVec2(10, 6));
  ImGui::TextUnformatted(text.c_str());
  ImGui::EndChild();
  ImGui::PopStyleColor(2);
}

/// The banners this frame: an armed quit, loading, tracking lost, paused.
int banners(const Installation& inst, const ConsoleState& c) {
  int shown = 0;
  const Timestamp t = now();
  if (const auto until = inst.quit_armed_until(t)) {
    const std::string key = key_for(inst, KeyAction{KeyAction::Kind::quit, OrderKind::punch_right, -1});
    banner("quit", fmt::format("QUIT?  press {} again within {:.0f} s to end the show", key.empty() ? "quit" : key,
                               std::ceil(*until - t)),
           ImVec4(0.65f, 0.1f, 0.1f, 1));
    ++shown;
  }
  if (inst.tracking_loading()) {
    banner("loading", "LOADING the tracking source: the show starts when it is in", ImVec4(0.15f, 0.3f, 0.6f, 1));
    ++shown;
  } else if (inst.has_tracker() && !c.head_live) {
    banner("lost", "TRACKING LOST: walls drawn from the last good head", ImVec4(0.7f, 0.15f, 0.1f, 1));
    ++shown;
  }
  if (c.paused) {
    banner("paused", "PAUSED: the fighter holds still and ignores strikes", ImVec4(0.7f, 0.45f, 0.0f, 1));
    ++shown;
  }
  return shown;
}

}  // namespace

void Console::frame(const Installation& inst, const FrameData& f, Installation* orders) {
  glfwMakeContextCurrent(window_);
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
  const ConsoleState c = inst.console();
  const bool loading = inst.tracking_loading();
  ImGui::SetNextWindowPos(ImVec2(0, 0));
  ImGui::SetNextWindowSize(ImGui::GetIO().DisplaySize);
  ImGui::Begin("Kumite supervisor", nullptr,
               ImGuiWindowFlags_NoResize | ImGuiWindowFlags_NoMove | ImGuiWindowFlags_NoCollapse |
                   ImGuiWindowFlags_NoScrollbar | ImGuiWindowFlags_NoScrollWithMouse);
  if (!orders)  // a replay: not the show
    banner("replay", fmt::format("REPLAY  frame {}  {:.1f} s  (no orders)", f.frame, f.time_s),
           ImVec4(0.35f, 0.2f, 0.55f, 1));
  banners(inst, c);
  ImGui::Text("%.1f fps   frame CPU %.3f ms   stereo %s   t = %.1f s", c.fps, c.frame_cpu_ms,
              std::string(to_string(mode_)).c_str(), f.time_s);
  // Upper part: orders and the key map (left), tracking and the fighter (right), each in a
  // region of its own so that nothing of one column draws through the other.
  const float upper_h = 405;
  ImGui::BeginChild("left", ImVec2(372, upper_h), false, ImGuiWindowFlags_NoScrollbar);
  ImGui::TextColored(kAmber, "Orders");
  order_button(inst, orders, "Punch left", OrderKind::punch_left);
  ImGui::SameLine();
  order_button(inst, orders, "Punch right", OrderKind::punch_right);
  order_button(inst, orders, "Kick left", OrderKind::kick_left);
  ImGui::SameLine();
  order_button(inst, orders, "Kick right", OrderKind::kick_right);
  for (int i = 0; i < inst.character_count(); ++i) {
    const std::string label = fmt::format("{} {}", i + 1, inst.character_name(i));
    order_button(inst, orders, label.c_str(), OrderKind::select_character, i);
    if (i % 2 == 0 && i + 1 < inst.character_count()) ImGui::SameLine();
  }
  order_button(inst, orders, c.paused ? "Resume" : "Pause", c.paused ? OrderKind::resume : OrderKind::pause);
  ImGui::SameLine();
  order_button(inst, orders, "Recentre", OrderKind::recentre);
  // (a row of its own: two 170-px buttons fill the column; a third beside them was cut off)
  {
    const auto st = inst.planner_status();
    const bool sparring = st && st->mode == content::PlannerMode::spar;
    order_button(inst, orders, sparring ? "Orders only" : "Spar", sparring ? OrderKind::orders_only : OrderKind::spar);
  }
  ImGui::Spacing();
  ImGui::TextColored(kAmber, "Key map");
  // Two pairs of columns: a dozen keys in six rows.
  if (ImGui::BeginTable("keys", 4, ImGuiTableFlags_SizingFixedFit)) {
    for (int col = 0; col < 4; ++col)
      ImGui::TableSetupColumn(nullptr, ImGuiTableColumnFlags_WidthFixed, col % 2 == 0 ? 62.0f : 112.0f);
    for (const auto& k : inst.config().keys) {
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(k.key.c_str());
      ImGui::TableNextColumn();
      ImGui::TextUnformatted(to_string(k.action).c_str());
    }
    ImGui::EndTable();
  }
  ImGui::EndChild();
  ImGui::SameLine();
  ImGui::BeginChild("right", ImVec2(0, upper_h), false, ImGuiWindowFlags_NoScrollbar);
  ImGui::TextColored(kAmber, "Tracking");
  ImGui::TextColored(loading ? kAmber : c.head_live ? kGreen : kRed, "head: %s", loading ? "loading" : c.tracking.c_str());
  if (!c.tracking_source.empty()) ImGui::TextWrapped("%s", c.tracking_source.c_str());
  if (!c.recognition.empty()) ImGui::TextWrapped("%s", c.recognition.c_str());
  ImGui::Text("head  [%.2f, %.2f, %.2f] m   markers %d", f.head.position.x, f.head.position.y,
              f.head.position.z, c.markers_seen);
  if (c.pose_age_ms >= 0 && c.tracking_latency_ms >= 0) {
    ImGui::Text("latency (pose age at render) %.1f ms", c.pose_age_ms);
    ImGui::TextWrapped("  = tracking %.1f + waiting for the display %.1f ms", c.tracking_latency_ms,
                       c.pose_age_ms - c.tracking_latency_ms);
  } else if (c.pose_age_ms >= 0) {
    ImGui::Text("latency (pose age at render) %.1f ms", c.pose_age_ms);
  } else {
    ImGui::Text("latency: no pose");
  }
  if (!c.late_latch)
    ImGui::TextWrapped("late latch off: pose taken at the frame's start");
  else if (c.draw_budget_ms < 0)
    ImGui::TextWrapped("late latch: measuring the drawing time");
  else if (c.draw_budget_ms >= 1e3 / inst.config().display_rate_hz)
    ImGui::TextWrapped("late latch: no room (drawing budget %.0f ms)", c.draw_budget_ms);
  else
    ImGui::TextWrapped("late latch: pose taken %.1f ms in (drawing budget %.1f ms)", c.latch_ms, c.draw_budget_ms);
  for (const auto& cam : c.cameras) {
    // While the source loads no camera has a frame yet: loading, not an alarm.
    const std::string last = loading                 ? std::string("waiting for the source to load")
                             : cam.since_last_ms >= 0 ? fmt::format("last frame {:.0f} ms ago", cam.since_last_ms)
                                                      : std::string("never a frame");
    ImGui::TextColored(loading ? kAmber : cam.state == CameraState::ok ? kGreen : kRed, "camera %-8s %-12s %3d blobs  %s",
                       cam.name.c_str(), loading ? "loading" : cam.status.c_str(), cam.blobs, last.c_str());
  }
  ImGui::Spacing();
  ImGui::TextColored(kAmber, "Fighter");
  ImGui::Text("state %s   character %d %s", c.fighter_state.c_str(), c.character + 1, c.character_name.c_str());
  ImGui::Text("last order %s", c.last_order.empty() ? "-" : c.last_order.c_str());
  ImGui::Text("outcome    %s", c.last_outcome.empty() ? "-" : c.last_outcome.c_str());
  if (!c.planner.empty()) ImGui::TextWrapped("planner    %s", c.planner.c_str());
  if (const SessionRecorder* r = inst.recorder())
    ImGui::TextColored(r->budget_reached() || r->dropped() > 0 ? kRed : kGreen, "%s", r->status_line().c_str());
  ImGui::EndChild();
  ImGui::Separator();
  ImGui::PushStyleColor(ImGuiCol_Text, kRed);  // long lines wrap rather than run off
  for (const auto& p : c.problems) ImGui::TextWrapped("! %s", p.c_str());
  ImGui::PopStyleColor();
  // Lower part: the top view beside the recent events, both in what is left of the window.
  const float lower_h = std::max(120.0f, ImGui::GetContentRegionAvail().y);
  ImGui::BeginChild("top_view", ImVec2(300, lower_h), false, ImGuiWindowFlags_NoScrollbar);
  top_view(inst, f);
  ImGui::EndChild();
  ImGui::SameLine();
  ImGui::BeginChild("events", ImVec2(0, lower_h));
  ImGui::TextColored(kAmber, "Recent events (newest first)");
  for (auto it = c.recent.rbegin(); it != c.recent.rend(); ++it) ImGui::TextWrapped("%s", it->c_str());
  ImGui::EndChild();
  ImGui::End();
  ImGui::Render();
  int w = 0, h = 0;
  glfwGetFramebufferSize(window_, &w, &h);
  glViewport(0, 0, w, h);
  glClearColor(0.08f, 0.08f, 0.1f, 1.0f);
  glClear(GL_COLOR_BUFFER_BIT);
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
}

void Console::swap() { glfwSwapBuffers(window_); }

}  // namespace kumite::app
