// crowdhealth-viewer — watch a scenario run, and change the SPH model's parameters while it runs.
//
//   crowdhealth-viewer SCENARIO [--color C] [--size WxH] [--paused] [--screenshot FILE --frames N]
//
// Drawn with GLFW and OpenGL 1.x/2.x (fixed function: runs on Mesa's software renderer, also
// under Xvfb). No text is drawn in the window: the title bar shows the time, the agent count and
// the current parameters; clicking an agent prints its record on standard output; H prints the
// controls. See docs/rendering.md.
#include "render_scene.h"
#include "screenshot.h"

#include <crowdhealth/core/simulation.h>

#include <GLFW/glfw3.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <memory>
#include <numbers>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

namespace {

using chrender::Colouring;

const char* kControls =
    "crowdhealth-viewer controls\n"
    "  Space          play / pause\n"
    "  N or Right     one step (pauses)\n"
    "  + / -          faster / slower (coarse steps per drawn frame: 1, 2, 4 … 64)\n"
    "  mouse wheel    zoom around the cursor;  drag (left or right button): pan;  F: fit the scene\n"
    "  left click     select an agent and print its record (click empty space to deselect)\n"
    "  C              next colouring: density, contact, panic, injury, none\n"
    "  1 2 3 4        choose the parameter to change: 1 rest density max (SPH restDensityMax),\n"
    "                 2 gas constant (SPH gasConstant), 3 preferred speed (every agent),\n"
    "                 4 goal strength (GoalReachingForce strength)\n"
    "  Up / Down      increase / decrease the chosen parameter (changes the running simulation)\n"
    "  P              print the parameters;  H: this help;  Esc or Q: quit\n";

struct Param {
    const char* label;
    const char* component;  ///< registered component name, or nullptr for the preferred speed
    const char* name;       ///< parameter name
    double step;            ///< change per key press
    double min, max;
};
const Param kParams[] = {
    {"rest density max (1/m²)", "SPH", "restDensityMax", 0.5, 0.0, 20.0},
    {"gas constant (m²/s²)", "SPH", "gasConstant", 25.0, 0.0, 5000.0},
    {"preferred speed (m/s)", nullptr, "pref_speed", 0.1, 0.0, 5.0},
    {"goal strength", "GoalReachingForce", "strength", 0.1, 0.0, 20.0},
};

struct Options {
    std::string scenario;
    Colouring colouring = Colouring::Density;
    int width = 1000, height = 800;
    bool paused = false;
    std::string screenshot;
    int frames = 0;
};

class Viewer {
public:
    Viewer(std::unique_ptr<ch::Simulation> sim, const Options& o) : sim_(std::move(sim)), o_(o) {
        scene_ = chrender::sceneBounds(sim_->spec());
        goals_ = chrender::goalMarks(sim_->spec());
        marks_ = chrender::venueMarks(sim_->spec());
        colouring_ = o.colouring;
        playing_ = !o.paused;
        prefSpeed_ = sim_->spec().agents.empty() ? 1.4 : sim_->spec().agents.front().prefSpeed;
    }

    int run();
    void setSpeed(int s) { speed_ = s; }

private:
    // simulation side
    void step(int n) {
        for (int k = 0; k < n && !sim_->finished(); ++k) sim_->stepCoarse();
    }
    double paramValue(const Param& p) const;
    void changeParam(const Param& p, double delta);
    void printParams() const;
    void printAgent(std::size_t i);
    void cycleColouring();

    // drawing
    void fitView(int w, int h);
    void draw(int w, int h);
    void updateTitle();
    ch::Vec2 toWorld(double sx, double sy) const;

    // GLFW callbacks
    static Viewer& self(GLFWwindow* w) { return *static_cast<Viewer*>(glfwGetWindowUserPointer(w)); }
    void onKey(int key, int action, int mods);
    void onScroll(double dy);
    void onButton(int button, int action);
    void onCursor(double x, double y);

    std::unique_ptr<ch::Simulation> sim_;
    Options o_;
    GLFWwindow* window_ = nullptr;
    chrender::Box scene_;
    std::vector<chrender::GoalMark> goals_;
    std::vector<chrender::VenueMark> marks_;  ///< targets and exits, in VenueSpec::targets order
    Colouring colouring_;
    bool playing_ = true;
    int speed_ = 1;
    int param_ = 0;
    double prefSpeed_ = 1.4;
    std::optional<ch::AgentId> selected_;
    // view: world point at the window centre and pixels per metre
    ch::Vec2 centre_{0, 0};
    double scale_ = 10;
    int fbw_ = 0, fbh_ = 0, winw_ = 0, winh_ = 0;
    bool dragging_ = false, moved_ = false;
    double lastX_ = 0, lastY_ = 0, pressX_ = 0, pressY_ = 0;
    std::string lastTitle_;
    double scaleBar_ = 1;  ///< length of the scale bar drawn in the last frame (m)
};

double Viewer::paramValue(const Param& p) const {
    if (!p.component) return prefSpeed_;
    for (const ch::Policy& pol : sim_->policies())
        for (const ch::PolicyStep& s : pol.steps())
            for (const auto& e : s.components())
                if (e.name == p.component) return e.component->parameter(p.name);
    return std::nan("");
}

void Viewer::changeParam(const Param& p, double delta) {
    const double old = paramValue(p);
    if (!std::isfinite(old)) {
        std::cout << "No " << p.component << " component in this scenario's policies: cannot change " << p.label
                  << "\n";
        return;
    }
    const double v = std::clamp(std::round((old + delta) / p.step) * p.step, p.min, p.max);
    if (!p.component) {
        prefSpeed_ = v;
        sim_->setPrefSpeed(v);
    } else {
        for (ch::Policy& pol : sim_->policies())
            for (ch::PolicyStep& s : pol.steps())
                for (auto& e : s.components())
                    if (e.name == p.component) e.component->setParameter(p.name, v);
    }
    std::cout << "t = " << sim_->time() << " s: " << p.label << " = " << v << "\n" << std::flush;
}

void Viewer::printParams() const {
    std::cout << "Parameters at t = " << sim_->time() << " s:";
    for (std::size_t k = 0; k < std::size(kParams); ++k) {
        const double v = paramValue(kParams[k]);
        std::cout << "  [" << k + 1 << "] " << kParams[k].label << " = ";
        if (std::isfinite(v)) std::cout << v;
        else std::cout << "(no " << kParams[k].component << ")";
    }
    std::cout << "\n" << std::flush;
}

void Viewer::printAgent(std::size_t i) {
    const ch::AgentStore& a = sim_->agents();
    sim_->measureDensity(1.0);
    std::cout << "agent " << a.id[i] << " at t = " << sim_->time() << " s: position (" << a.pos[i].x() << ", "
              << a.pos[i].y() << ") m, speed " << a.vel[i].norm() << " m/s, density " << a.density[i]
              << " 1/m², contact acceleration " << a.contactAccel[i].norm() << " m/s², radius " << a.radius[i]
              << " m";
    const ch::HealthRecord& h = sim_->health().recordOf(a, i);
    std::cout << ", panic " << h.panic << ", peak force " << h.peakForce << " N, crush dose " << h.dose << " N s"
              << (h.injured() ? ", injured" : "");
    std::cout << "\n" << std::flush;
}

void Viewer::cycleColouring() {
    const Colouring order[] = {Colouring::Density, Colouring::Contact, Colouring::Panic, Colouring::Injury,
                               Colouring::None};
    int k = 0;
    while (order[k] != colouring_) ++k;
    colouring_ = order[(k + 1) % 5];
    std::cout << "colouring: " << chrender::colouringName(colouring_) << "\n" << std::flush;
}

void Viewer::fitView(int w, int h) {
    centre_ = {(scene_.xmin + scene_.xmax) / 2, (scene_.ymin + scene_.ymax) / 2};
    const double usable = std::max(1, w - 50);  // room for the colour bar
    scale_ = std::min(usable / scene_.width(), h / scene_.height());
    centre_.x() += 25 / scale_;
}

ch::Vec2 Viewer::toWorld(double sx, double sy) const {
    // window coordinates (top-left origin, screen units) → framebuffer pixels → world
    const double px = sx * fbw_ / std::max(1, winw_), py = sy * fbh_ / std::max(1, winh_);
    return {centre_.x() + (px - fbw_ / 2.0) / scale_, centre_.y() - (py - fbh_ / 2.0) / scale_};
}

void disc(double x, double y, double r, int n = 20) {
    glBegin(GL_TRIANGLE_FAN);
    glVertex2d(x, y);
    for (int k = 0; k <= n; ++k) {
        const double a = 2 * std::numbers::pi * k / n;
        glVertex2d(x + r * std::cos(a), y + r * std::sin(a));
    }
    glEnd();
}
void ring(double x, double y, double r, int n = 24) {
    glBegin(GL_LINE_LOOP);
    for (int k = 0; k < n; ++k) {
        const double a = 2 * std::numbers::pi * k / n;
        glVertex2d(x + r * std::cos(a), y + r * std::sin(a));
    }
    glEnd();
}

void Viewer::draw(int w, int h) {
    glViewport(0, 0, w, h);
    glClearColor(1, 1, 1, 1);
    glClearStencil(0);
    glClear(GL_COLOR_BUFFER_BIT | GL_STENCIL_BUFFER_BIT);
    glMatrixMode(GL_PROJECTION);
    glLoadIdentity();
    const double hw = w / 2.0 / scale_, hh = h / 2.0 / scale_;
    glOrtho(centre_.x() - hw, centre_.x() + hw, centre_.y() - hh, centre_.y() + hh, -1, 1);
    glMatrixMode(GL_MODELVIEW);
    glLoadIdentity();

    // obstacles: any simple polygon, filled with the stencil (even-odd) trick, then outlined
    for (const ch::ObstacleSpec& ob : sim_->spec().obstacles) {
        if (ob.points.size() < 3) continue;
        glEnable(GL_STENCIL_TEST);
        glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
        glStencilFunc(GL_ALWAYS, 0, 1);
        glStencilOp(GL_KEEP, GL_KEEP, GL_INVERT);
        glBegin(GL_TRIANGLE_FAN);
        for (const ch::Vec2& p : ob.points) glVertex2d(p.x(), p.y());
        glEnd();
        glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
        glStencilFunc(GL_EQUAL, 1, 1);
        glStencilOp(GL_ZERO, GL_ZERO, GL_ZERO);  // and clear it for the next obstacle
        glColor3d(0.55, 0.55, 0.55);
        glBegin(GL_TRIANGLE_FAN);
        for (const ch::Vec2& p : ob.points) glVertex2d(p.x(), p.y());
        glEnd();
        glDisable(GL_STENCIL_TEST);
        glColor3d(0.35, 0.35, 0.35);
        glBegin(GL_LINE_LOOP);
        for (const ch::Vec2& p : ob.points) glVertex2d(p.x(), p.y());
        glEnd();
    }

    // wall segments (obstacles of two points: no area to fill)
    glLineWidth(2);
    glColor3d(0.35, 0.35, 0.35);
    glBegin(GL_LINES);
    for (const ch::ObstacleSpec& ob : sim_->spec().obstacles)
        if (ob.points.size() == 2) {
            glVertex2d(ob.points[0].x(), ob.points[0].y());
            glVertex2d(ob.points[1].x(), ob.points[1].y());
        }
    glEnd();

    // targets (blue) and exits (green; red and dashed while closed) of a venue. No text: the
    // names are in the scenario file and in the frames of `crowdhealth render`.
    for (std::size_t k = 0; k < marks_.size(); ++k) {
        const chrender::VenueMark& m = marks_[k];
        const bool open = !m.exit || sim_->navigation() == nullptr || sim_->navigation()->open(static_cast<int>(k));
        if (!m.exit) glColor3d(0.12, 0.37, 0.75);
        else if (open) glColor3d(0.10, 0.59, 0.25);
        else glColor3d(0.84, 0.10, 0.11);
        if (!open) {
            glEnable(GL_LINE_STIPPLE);
            glLineStipple(3, 0x3333);
        }
        if (m.point) {
            ring(m.centre.x(), m.centre.y(), std::max(m.radius, 0.15));
        } else {
            glBegin(GL_LINE_LOOP);
            for (const ch::Vec2& p : m.outline) glVertex2d(p.x(), p.y());
            glEnd();
        }
        if (!open) glDisable(GL_LINE_STIPPLE);
    }

    // goals
    glColor3d(0.88, 0.44, 0.0);
    for (const auto& g : goals_) ring(g.position.x(), g.position.y(), std::max(g.radius, 0.15));
    glLineWidth(1);

    // agents
    const std::vector<double> values = chrender::agentValues(*sim_, colouring_);
    double vmax = 1;
    if (colouring_ == Colouring::Contact)
        for (const double v : values) vmax = std::max(vmax, v);
    auto colourOf = [&](double v) {
        switch (colouring_) {
            case Colouring::Density: return chrender::densityColour(v);
            case Colouring::Contact: return chrender::heatColour(v / vmax);
            case Colouring::Panic:
            case Colouring::Injury: return chrender::heatColour(v);
            case Colouring::None: break;
        }
        return chrender::Rgb{0.35, 0.55, 0.85};
    };
    const ch::AgentStore& a = sim_->agents();
    for (std::size_t i = 0; i < a.size(); ++i) {
        const chrender::Rgb c = colourOf(values[i]);
        glColor3d(c.r, c.g, c.b);
        disc(a.pos[i].x(), a.pos[i].y(), a.radius[i]);
        glColor3d(0.15, 0.15, 0.15);
        ring(a.pos[i].x(), a.pos[i].y(), a.radius[i], 20);
        if (selected_ && a.id[i] == *selected_) {
            glLineWidth(3);
            glColor3d(0, 0, 0);
            ring(a.pos[i].x(), a.pos[i].y(), a.radius[i] + 0.12);
            glLineWidth(1);
        }
    }

    // screen-space overlays: colour bar (right) and a 5 m-style scale bar (bottom left)
    glMatrixMode(GL_PROJECTION);
    glLoadIdentity();
    glOrtho(0, w, 0, h, -1, 1);
    if (colouring_ != Colouring::None) {
        const double x0 = w - 35, x1 = w - 15, y0 = 20, y1 = h - 20;
        const int n = 100;
        const double top = colouring_ == Colouring::Density ? 8 : colouring_ == Colouring::Contact ? vmax : 1;
        glBegin(GL_QUADS);
        for (int k = 0; k < n; ++k) {
            const chrender::Rgb c = colourOf(top * (k + 0.5) / n);
            glColor3d(c.r, c.g, c.b);
            const double ya = y0 + (y1 - y0) * k / n, yb = y0 + (y1 - y0) * (k + 1) / n;
            glVertex2d(x0, ya); glVertex2d(x1, ya); glVertex2d(x1, yb); glVertex2d(x0, yb);
        }
        glEnd();
        glColor3d(0.25, 0.25, 0.25);
        glBegin(GL_LINE_LOOP);
        glVertex2d(x0, y0); glVertex2d(x1, y0); glVertex2d(x1, y1); glVertex2d(x0, y1);
        glEnd();
    }
    double len = 1;  // a 1/2/5 × 10^k m bar about 100 pixels long
    for (double p = 1e-3; p < 1e6; p *= 10)
        for (const double f : {1.0, 2.0, 5.0})
            if (f * p * scale_ <= 150) len = f * p;
    glLineWidth(4);
    glColor3d(0, 0, 0);
    glBegin(GL_LINES);
    glVertex2d(20, 20);
    glVertex2d(20 + len * scale_, 20);
    glEnd();
    glLineWidth(1);
    scaleBar_ = len;
}

void Viewer::updateTitle() {
    std::ostringstream t;
    t.precision(3);
    t << "CrowdHealth — t = " << std::fixed << sim_->time() << " s, " << sim_->agents().size() << " agents, "
      << (playing_ ? "playing" : "paused") << " ×" << speed_ << ", colour " << chrender::colouringName(colouring_)
      << ", scale bar " << std::defaultfloat << scaleBar_ << " m | [" << param_ + 1 << "] "
      << kParams[param_].label << " = " << paramValue(kParams[param_]) << " (H: help)";
    if (t.str() != lastTitle_) {
        lastTitle_ = t.str();
        glfwSetWindowTitle(window_, lastTitle_.c_str());
    }
}

void Viewer::onKey(int key, int action, int mods) {
    (void)mods;
    if (action != GLFW_PRESS && action != GLFW_REPEAT) return;
    switch (key) {
        case GLFW_KEY_ESCAPE:
        case GLFW_KEY_Q: glfwSetWindowShouldClose(window_, GLFW_TRUE); break;
        case GLFW_KEY_SPACE: playing_ = !playing_; break;
        case GLFW_KEY_N:
        case GLFW_KEY_RIGHT: playing_ = false; step(1); break;
        case GLFW_KEY_EQUAL:
        case GLFW_KEY_KP_ADD: speed_ = std::min(64, speed_ * 2); break;
        case GLFW_KEY_MINUS:
        case GLFW_KEY_KP_SUBTRACT: speed_ = std::max(1, speed_ / 2); break;
        case GLFW_KEY_F: fitView(fbw_, fbh_); break;
        case GLFW_KEY_C: cycleColouring(); break;
        case GLFW_KEY_1: case GLFW_KEY_2: case GLFW_KEY_3: case GLFW_KEY_4:
            param_ = key - GLFW_KEY_1;
            std::cout << "parameter: " << kParams[param_].label << " = " << paramValue(kParams[param_]) << "\n"
                      << std::flush;
            break;
        case GLFW_KEY_UP: changeParam(kParams[param_], kParams[param_].step); break;
        case GLFW_KEY_DOWN: changeParam(kParams[param_], -kParams[param_].step); break;
        case GLFW_KEY_P: printParams(); break;
        case GLFW_KEY_H: std::cout << kControls << std::flush; break;
        default: break;
    }
}

void Viewer::onScroll(double dy) {
    const ch::Vec2 before = toWorld(lastX_, lastY_);
    scale_ = std::clamp(scale_ * std::pow(1.15, dy), 0.5, 2000.0);
    const ch::Vec2 after = toWorld(lastX_, lastY_);
    centre_ += before - after;  // keep the point under the cursor in place
}

void Viewer::onButton(int button, int action) {
    if (button != GLFW_MOUSE_BUTTON_LEFT && button != GLFW_MOUSE_BUTTON_RIGHT) return;
    if (action == GLFW_PRESS) {
        dragging_ = true;
        moved_ = false;
        pressX_ = lastX_;
        pressY_ = lastY_;
        return;
    }
    dragging_ = false;
    if (button != GLFW_MOUSE_BUTTON_LEFT || moved_) return;
    // a click: the agent under the cursor
    const ch::Vec2 p = toWorld(lastX_, lastY_);
    const ch::AgentStore& a = sim_->agents();
    selected_.reset();
    for (std::size_t i = 0; i < a.size(); ++i)
        if ((a.pos[i] - p).norm() <= a.radius[i] + 0.05) {
            selected_ = a.id[i];
            printAgent(i);
            break;
        }
}

void Viewer::onCursor(double x, double y) {
    if (dragging_) {
        if (std::hypot(x - pressX_, y - pressY_) > 3) moved_ = true;
        if (moved_) centre_ -= toWorld(x, y) - toWorld(lastX_, lastY_);
    }
    lastX_ = x;
    lastY_ = y;
}

int Viewer::run() {
    glfwWindowHint(GLFW_STENCIL_BITS, 8);
    glfwWindowHint(GLFW_SAMPLES, o_.screenshot.empty() ? 4 : 0);
    if (!o_.screenshot.empty()) glfwWindowHint(GLFW_RESIZABLE, GLFW_FALSE);
    window_ = glfwCreateWindow(o_.width, o_.height, "CrowdHealth", nullptr, nullptr);
    if (!window_) {
        std::cerr << "crowdhealth-viewer: error: cannot open an OpenGL window (no display? try xvfb-run -a)\n";
        return 1;
    }
    glfwMakeContextCurrent(window_);
    glfwSwapInterval(o_.screenshot.empty() ? 1 : 0);
    glfwSetWindowUserPointer(window_, this);
    glfwSetKeyCallback(window_, [](GLFWwindow* w, int k, int, int a, int m) { self(w).onKey(k, a, m); });
    glfwSetScrollCallback(window_, [](GLFWwindow* w, double, double dy) { self(w).onScroll(dy); });
    glfwSetMouseButtonCallback(window_, [](GLFWwindow* w, int b, int a, int) { self(w).onButton(b, a); });
    glfwSetCursorPosCallback(window_, [](GLFWwindow* w, double x, double y) { self(w).onCursor(x, y); });
    glfwGetFramebufferSize(window_, &fbw_, &fbh_);
    glfwGetWindowSize(window_, &winw_, &winh_);
    fitView(fbw_, fbh_);
    if (o_.screenshot.empty()) {
        std::cout << kControls << std::flush;
        printParams();
    }

    int frame = 0;
    while (!glfwWindowShouldClose(window_)) {
        glfwPollEvents();
        int w, h;
        glfwGetFramebufferSize(window_, &w, &h);
        glfwGetWindowSize(window_, &winw_, &winh_);
        if (w != fbw_ || h != fbh_) {
            // keep the scale; the view centre stays
            fbw_ = w;
            fbh_ = h;
        }
        if (playing_) step(speed_);
        draw(fbw_, fbh_);
        updateTitle();
        ++frame;
        if (!o_.screenshot.empty() && frame >= o_.frames) {
            glFinish();
            std::vector<std::uint8_t> px(static_cast<std::size_t>(fbw_) * fbh_ * 3);
            glPixelStorei(GL_PACK_ALIGNMENT, 1);
            glReadBuffer(GL_BACK);
            glReadPixels(0, 0, fbw_, fbh_, GL_RGB, GL_UNSIGNED_BYTE, px.data());
            std::vector<std::uint8_t> flipped(px.size());  // OpenGL rows go bottom-up
            const std::size_t row = static_cast<std::size_t>(fbw_) * 3;
            for (int y = 0; y < fbh_; ++y)
                std::copy_n(px.begin() + static_cast<std::ptrdiff_t>(y * row), row,
                            flipped.begin() + static_cast<std::ptrdiff_t>((fbh_ - 1 - y) * row));
            const std::string err = chviewer::writeImage(o_.screenshot, fbw_, fbh_, flipped);
            if (!err.empty()) {
                std::cerr << "crowdhealth-viewer: error: " << err << "\n";
                return 1;
            }
            std::cout << "Saved " << o_.screenshot << " (" << fbw_ << "x" << fbh_ << ") after " << frame
                      << " frames, t = " << sim_->time() << " s\n";
            break;
        }
        glfwSwapBuffers(window_);
    }
    glfwDestroyWindow(window_);
    return 0;
}

int usage(const std::string& msg) {
    std::cerr << "crowdhealth-viewer: error: " << msg
              << "\nUsage: crowdhealth-viewer SCENARIO [--color density|contact|panic|injury|none] [--size WxH] "
                 "[--speed N] [--paused] [--screenshot FILE --frames N]\n";
    return 2;
}

}  // namespace

int main(int argc, char* argv[]) {
    Options o;
    int speed = 1;
    for (int k = 1; k < argc; ++k) {
        const std::string a = argv[k];
        auto value = [&](std::string& out) {
            if (k + 1 >= argc) return false;
            out = argv[++k];
            return true;
        };
        std::string v;
        if (a == "-h" || a == "--help") {
            std::cout << "Usage: crowdhealth-viewer SCENARIO [--color density|contact|panic|injury|none] [--size WxH]\n"
                         "                          [--speed N] [--paused] [--screenshot FILE --frames N]\n\n"
                         "--screenshot FILE --frames N: run N frames without interaction, save the window as FILE\n"
                         "(PNG, or PPM if FILE ends in .ppm) and exit.\n\n"
                      << kControls;
            return 0;
        } else if (a == "--color") {
            if (!value(v)) return usage("--color needs a value");
            const auto c = chrender::parseColouring(v);
            if (!c) return usage("--color must be density, contact, panic, injury or none");
            o.colouring = *c;
        } else if (a == "--size") {
            if (!value(v) || std::sscanf(v.c_str(), "%dx%d", &o.width, &o.height) != 2 || o.width < 200 ||
                o.height < 150 || o.width > 8000 || o.height > 8000)
                return usage("--size must be WxH, e.g. 1000x800");
        } else if (a == "--speed") {
            if (!value(v)) return usage("--speed needs a value");
            speed = std::atoi(v.c_str());
            if (speed < 1 || speed > 64) return usage("--speed must be 1 … 64 coarse steps per frame");
        } else if (a == "--paused") {
            o.paused = true;
        } else if (a == "--screenshot") {
            if (!value(o.screenshot)) return usage("--screenshot needs a file name");
        } else if (a == "--frames") {
            if (!value(v)) return usage("--frames needs a number");
            o.frames = std::atoi(v.c_str());
            if (o.frames < 1) return usage("--frames must be ≥ 1");
        } else if (!a.empty() && a[0] == '-') {
            return usage("unknown option " + a);
        } else if (o.scenario.empty()) {
            o.scenario = a;
        } else {
            return usage("give one scenario file");
        }
    }
    if (o.scenario.empty()) return usage("give a scenario file");
    if (!o.screenshot.empty() && o.frames < 1) o.frames = 1;
    if (o.screenshot.empty() && o.frames > 0) return usage("--frames goes with --screenshot FILE");

    const std::optional<ch::ScenarioSpec> spec = chrender::loadForDisplay(o.scenario, std::cerr);
    if (!spec) return 2;
    std::unique_ptr<ch::Simulation> sim;
    try {
        sim = std::make_unique<ch::Simulation>(*spec);
    } catch (const std::exception& e) {
        std::cerr << o.scenario << ": error: " << e.what() << "\n";
        return 2;
    }
    sim->setThreads(static_cast<int>(std::max(1u, std::thread::hardware_concurrency())));

    glfwSetErrorCallback([](int code, const char* msg) { std::cerr << "crowdhealth-viewer: GLFW error " << code << ": " << msg << "\n"; });
    if (!glfwInit()) {
        std::cerr << "crowdhealth-viewer: error: GLFW could not start (no display? run it under xvfb-run -a for "
                     "--screenshot)\n";
        return 1;
    }
    int status = 1;
    {
        Viewer viewer(std::move(sim), o);
        viewer.setSpeed(speed);
        status = viewer.run();
    }
    glfwTerminate();
    return status;
}
