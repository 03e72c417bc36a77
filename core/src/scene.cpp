// Loads and validates `cloudscene` version 1 files (data/scene-format.md).
//
// Every value is read through a small typed reader that knows its JSON path, so a fault
// names the exact place: "scene.json: clouds[2].ellipsoids[5].radii[1]: must be > 0, got -3".
// Objects are read through Obj, which records the keys asked for and rejects the others.
#include "nephele/scene.hpp"

#include "nephele/generate.hpp"
#include "nephele/limits.hpp"
#include "nephele/scene_text.hpp"

#include "input_file.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string_view>
#include <type_traits>
#include <unordered_set>
#include <utility>

namespace nephele {

SceneError::SceneError(std::string file, std::string jsonPath, std::string fault)
    : std::runtime_error(file + ": " + (jsonPath.empty() ? "" : jsonPath + ": ") + fault),
      file_(std::move(file)),
      path_(std::move(jsonPath)),
      fault_(std::move(fault)) {}

namespace {

using json = nlohmann::json;
using Path = std::string;  // a JSON path such as "clouds[2].ellipsoids[5].radii[1]"

// A fault at a JSON path; parseScene adds the file name and rethrows it as a SceneError.
struct Invalid {
    Path path;
    std::string fault;
};

[[noreturn]] void fail(Path path, std::string fault) { throw Invalid{std::move(path), std::move(fault)}; }

// A key or string as a message shows it: control characters escaped, at most `max` characters.
std::string printable(std::string_view s, std::size_t max = 256) {
    std::string out;
    for (const char c : s.substr(0, max)) {
        if (static_cast<unsigned char>(c) >= 0x20 && c != 0x7f) {
            out += c;
            continue;
        }
        char buf[8];
        std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned char>(c));
        out += buf;
    }
    return s.size() > max ? out + "..." : out;
}

Path member(const Path& path, std::string_view key) {
    return path.empty() ? printable(key, 64) : path + "." + printable(key, 64);
}
Path element(const Path& path, size_t i) { return path + "[" + std::to_string(i) + "]"; }

// Shortest text that reads back as the same double: "-3", "0.1", "100000", "1e+20".
std::string str(double v) {
    char buf[400];  // fixed notation of a double below 1e15 fits easily
    const bool fixed = v == 0 || (std::abs(v) >= 1e-4 && std::abs(v) < 1e15);
    const auto end = fixed ? std::to_chars(buf, buf + sizeof buf, v, std::chars_format::fixed).ptr
                           : std::to_chars(buf, buf + sizeof buf, v).ptr;
    return std::string(buf, end);
}
std::string inQuotes(std::string_view s) { return "'" + printable(s) + "'"; }

// What was found, for "expected X, got Y".
std::string describe(const json& j) {
    if (j.is_number()) return str(j.get<double>());
    if (j.is_boolean()) return j.get<bool>() ? "true" : "false";
    if (j.is_string()) return "a string";
    if (j.is_object()) return "an object";
    if (j.is_array()) {
        if (j.empty()) return "an empty array";
        return "an array of " + std::to_string(j.size()) + (j.size() == 1 ? " element" : " elements");
    }
    return j.type_name();  // "null"
}

// ---------------------------------------------------------------- JSON text

// nlohmann's "[json.exception.parse_error.101] parse error at line 3, column 5: syntax error
// while parsing object key - invalid literal; ..." becomes
// "syntax error at line 3, column 5: invalid literal; ...".
std::string syntaxFault(const std::string& what) {
    std::string s = what.substr(what.find("] ") == std::string::npos ? 0 : what.find("] ") + 2);
    const size_t at = s.find("at line "), colon = s.find(": ", at);
    if (at == std::string::npos || colon == std::string::npos) return "syntax error: " + s;
    std::string detail = s.substr(colon + 2);
    if (const size_t dash = detail.find(" - ");
        detail.starts_with("syntax error while parsing") && dash != std::string::npos)
        detail = detail.substr(dash + 3);
    if (detail.size() > 200) detail = detail.substr(0, 200) + "...";  // "last read" may hold a whole long token
    return "syntax error " + s.substr(at, colon - at) + ": " + detail;
}

// Builds the document from the parser's SAX events, in time and memory linear in the text:
// it knows the JSON path of the value being parsed (a stack of one key or index per level,
// turned into text only for a message), rejects duplicate keys (nlohmann would silently keep
// the last one), nesting deeper than the limit and more values than the limit, and does not
// keep comments (values of keys that begin with '_'), which nothing reads. (nlohmann's callback
// parser, used before, rescanned the parent container at every object's end: quadratic in an
// array's length.)
class DocumentBuilder {
public:
    explicit DocumentBuilder(json& root) : root_(root) {}

    bool null() { return put(nullptr); }
    bool boolean(bool v) { return put(v); }
    bool number_integer(json::number_integer_t v) { return put(v); }
    bool number_unsigned(json::number_unsigned_t v) { return put(v); }
    bool number_float(json::number_float_t v, const json::string_t&) { return put(v); }
    bool string(json::string_t& v) { return put(std::move(v)); }
    bool binary(json::binary_t&) { fail(here(), "binary values are not JSON text"); }
    bool start_object(std::size_t) { return open(json::value_t::object); }
    bool start_array(std::size_t) { return open(json::value_t::array); }
    bool end_object() { return close(); }
    bool end_array() { return close(); }
    bool key(json::string_t& k) {
        if (discarded_ > 0) return true;
        Level& l = levels_.back();
        comment_ = k.starts_with('_');
        const bool duplicate = !comment_ && l.node->contains(k);
        l.key = std::move(k);
        if (duplicate) fail(here(), "duplicate key " + inQuotes(l.key));
        return true;
    }
    bool parse_error(std::size_t, const std::string&, const nlohmann::detail::exception& e) {
        const std::string what = e.what();
        if (e.id == 406)  // out_of_range: a number such as 1e400 that overflows a double
            fail(here(), "not a finite number (" + what.substr(what.find("] ") + 2) + ")");
        fail("", syntaxFault(what));
    }

    // The path of the value being parsed now: an enclosing array's last element is the
    // container being filled; the innermost array's next element is the value being parsed.
    Path here() const {
        Path p;
        for (size_t i = 0; i < levels_.size(); ++i) {
            const Level& l = levels_[i];
            const size_t next = l.node->size() - (i + 1 < levels_.size() ? 1 : 0);
            p = l.node->is_array() ? element(p, next) : l.key.empty() ? p : member(p, l.key);
        }
        return p;
    }

private:
    struct Level {
        json* node;       // the object or array being filled
        std::string key;  // object: the key of the value being parsed
    };

    // Stores v where the parser is (the root, the next element, or the value of the current
    // key) and returns it; null for a comment's value.
    json* place(json&& v) {
        if (discarded_ > 0 || std::exchange(comment_, false)) return nullptr;
        if (double(++values_) > limits::kJsonValues.value)
            fail(here(), "the document holds more values than the limit " + limitText(limits::kJsonValues));
        if (levels_.empty()) {
            root_ = std::move(v);
            return &root_;
        }
        Level& l = levels_.back();
        if (l.node->is_array()) {
            auto& array = l.node->get_ref<json::array_t&>();
            array.push_back(std::move(v));
            return &array.back();
        }
        json& slot = (*l.node)[l.key];
        slot = std::move(v);
        return &slot;
    }
    template <class T>
    bool put(T&& v) {
        place(json(std::forward<T>(v)));
        return true;
    }
    bool open(json::value_t type) {
        if (double(levels_.size() + discarded_) >= limits::kNestingDepth.value)
            fail(here(), "nested deeper than the limit " + limitText(limits::kNestingDepth));
        if (json* node = place(json(type))) levels_.push_back({node, {}});
        else ++discarded_;  // a comment's object or array: skipped to its end
        return true;
    }
    bool close() {
        if (discarded_ > 0) --discarded_;
        else levels_.pop_back();
        return true;
    }

    json& root_;
    std::vector<Level> levels_;
    std::size_t discarded_ = 0;  // open containers inside a comment
    bool comment_ = false;       // the next value is a comment's
    std::size_t values_ = 0;
};

json parseJson(const std::string& text) {
    if (auto fault = detail::nulByteFault(text)) fail("", *fault);  // nlohmann would stop at a NUL
    if (text.find_first_not_of(" \t\r\n") == std::string::npos) fail("", "the file is empty");
    json root;
    DocumentBuilder builder(root);
    json::sax_parse(text, &builder);
    return root;
}

// ---------------------------------------------------------------- typed readers

constexpr double kInf = std::numeric_limits<double>::infinity();

// An interval of accepted numbers (the format's rule; ends are open or closed), and the
// project's limits on top of it (nephele/limits.hpp), reported as limits when hit.
struct Range {
    double lo = -kInf, hi = kInf;
    bool loOpen = false, hiOpen = false;
    const Limit* upper = nullptr;  // a Limit on the largest value (on |v| with `magnitude`)
    const Limit* lower = nullptr;  // a minimum Limit
    bool magnitude = false;

    bool contains(double v) const { return (loOpen ? v > lo : v >= lo) && (hiOpen ? v < hi : v <= hi); }
    std::string text() const {
        if (hi == kInf) return (loOpen ? "> " : ">= ") + str(lo);
        if (lo == -kInf) return (hiOpen ? "< " : "<= ") + str(hi);
        return std::string("in ") + (loOpen ? "(" : "[") + str(lo) + ", " + str(hi) + (hiOpen ? ")" : "]");
    }
};
constexpr Range atLeast(double lo) { return {lo, kInf, false, false}; }
constexpr Range above(double lo) { return {lo, kInf, true, false}; }
constexpr Range inclusive(double lo, double hi) { return {lo, hi, false, false}; }
constexpr Range exclusive(double lo, double hi) { return {lo, hi, true, true}; }
constexpr Range halfOpen(double lo, double hi) { return {lo, hi, false, true}; }  // [lo, hi)
constexpr Range capped(Range r, const Limit& limit) {
    (limit.minimum ? r.lower : r.upper) = &limit;
    return r;
}
constexpr Range coordinate() { return {-kInf, kInf, false, false, &limits::kCoordinate, nullptr, true}; }  // m
constexpr Range timeOfDay() { return {-kInf, kInf, false, false, &limits::kTime, nullptr, true}; }         // s

// Rejects v past `limit` ("2e+06 is over the limit 'ellipsoid radius' (100000 m)").
void checkLimit(double v, const Path& p, const Limit& limit, bool magnitude = false) {
    if (withinLimit(magnitude ? std::abs(v) : v, limit)) return;
    fail(p, (magnitude ? "|" + str(v) + "|" : str(v)) + " is " + (limit.minimum ? "under" : "over") + " the limit " +
                limitText(limit));
}
// Rejects a count past `limit` ("has 9 elements, over the limit 'layers' (8)").
void checkCount(std::size_t n, const Path& p, const Limit& limit, const std::string& what = "elements") {
    if (double(n) > limit.value)
        fail(p, "has " + std::to_string(n) + " " + what + ", over the limit " + limitText(limit));
}

// The renderers take numbers as floats. A number below float's normal range (0 < |v| <
// FLT_MIN, about 1.2e-38) is nonzero in the loader's doubles but a subnormal or zero in the
// shaders, where llvmpipe flushes subnormals: a sun of intensity 1e-39 passed "> 0" on the CPU
// and was divided by as 0 on the GPU, NaN (issue 38). Such a number is read as 0, which every
// part sees alike, and the field's range is checked on that 0.
double flushBelowFloat(double v) { return std::abs(v) < double(std::numeric_limits<float>::min()) ? 0.0 : v; }

double readNumber(const json& j, const Path& p, Range r = {}) {
    if (!j.is_number()) fail(p, "expected a number, got " + describe(j));
    const double given = j.get<double>();
    if (!std::isfinite(given)) fail(p, "must be finite, got " + str(given));
    const double v = flushBelowFloat(given);
    const std::string flushed =
        v != given ? " (below float range " + str(double(std::numeric_limits<float>::min())) + ": read as 0)" : "";
    if (!r.contains(v)) fail(p, "must be " + r.text() + ", got " + str(given) + flushed);
    if (r.upper) checkLimit(v, p, *r.upper, r.magnitude);
    if (r.lower && !withinLimit(v, *r.lower))
        fail(p, str(given) + " is under the limit " + limitText(*r.lower) + flushed);
    return v;
}

// An integer in lo..hi; a JSON float with an integral value (640.0) is accepted. With `limit`,
// hi is that limit, and a value over it is reported as over the limit.
long long readInteger(const json& j, const Path& p, long long lo, long long hi, const Limit* limit = nullptr) {
    if (!j.is_number()) fail(p, "expected an integer, got " + describe(j));
    const double v = j.get<double>();  // exact for every range used here (|v| < 2^53)
    if (!std::isfinite(v) || v != std::floor(v)) fail(p, "expected an integer, got " + str(v));
    if (limit && v > static_cast<double>(hi)) checkLimit(v, p, *limit);
    if (v < static_cast<double>(lo) || v > static_cast<double>(hi))
        fail(p, "must be in " + std::to_string(lo) + ".." + std::to_string(hi) + ", got " + str(v));
    return static_cast<long long>(v);
}

template <int N>
glm::vec<N, double> readVec(const json& j, const Path& p, Range r = {}) {
    if (!j.is_array() || j.size() != N)
        fail(p, "expected an array of " + std::to_string(N) + " numbers, got " + describe(j));
    glm::vec<N, double> v;
    for (int i = 0; i < N; ++i) v[i] = readNumber(j[i], element(p, i), r);
    return v;
}

// The shortest vector that gives a direction (its largest component). Directions end as floats
// in the renderers; one much shorter than this is a typo or a hostile input rather than a
// direction (issue 38: an up of [0, 0, 1e-200] was accepted and gave a sky-only image).
constexpr double kShortestDirection = 1e-6;

// v normalised; `zeroFault` if it has no direction, and a fault naming kShortestDirection if
// it is shorter than that.
Vec3 unit(const Vec3& v, const Path& p, const std::string& zeroFault) {
    const Vec3 a = glm::abs(v);
    const double m = std::max({a.x, a.y, a.z});  // scale first: |v|^2 may under- or overflow
    if (!std::isfinite(m)) fail(p, "gives a direction too long to represent");
    if (m == 0) fail(p, zeroFault);
    if (m < kShortestDirection)
        fail(p, "is too short to give a direction: its largest component " + str(m) + " is under " +
                    str(kShortestDirection));
    return glm::normalize(v / m);
}

// The direction from `from` to `to`, points of the scene (look_at - position): the difference
// must be a direction (unit) and long enough against the points' own size that the float
// positions the renderers use still differ by it (float keeps about 7 digits: 1e-6 of the
// largest coordinate is a few float steps).
Vec3 unitBetween(const Vec3& from, const Vec3& to, const Path& p, const std::string& zeroFault) {
    const Vec3 d = to - from;
    const Vec3 a = glm::abs(d);
    const double m = std::max({a.x, a.y, a.z});
    const double size = std::max(
        {std::abs(from.x), std::abs(from.y), std::abs(from.z), std::abs(to.x), std::abs(to.y), std::abs(to.z)});
    if (m > 0 && m < 1e-6 * size)
        fail(p, "is " + str(m) + " m from position, too close at coordinates of " + str(size) +
                    " m to give a direction in float (at least 1e-06 of the largest coordinate)");
    return unit(d, p, zeroFault);
}

// Reader factories: each returns a callable (const json&, const Path&) -> value.
auto number(Range r = {}) {
    return [r](const json& j, const Path& p) { return readNumber(j, p, r); };
}
auto integer(long long lo, long long hi, const Limit* limit = nullptr) {
    return [lo, hi, limit](const json& j, const Path& p) { return readInteger(j, p, lo, hi, limit); };
}
auto seed() { return integer(0, std::numeric_limits<std::uint32_t>::max()); }
auto vec2() {
    return [](const json& j, const Path& p) { return readVec<2>(j, p); };
}
auto vec3(Range r = {}) {
    return [r](const json& j, const Path& p) { return readVec<3>(j, p, r); };
}
auto color() { return vec3(capped(atLeast(0), limits::kColour)); }  // linear RGB, each component >= 0
auto intensity() { return number(capped(atLeast(0), limits::kIntensity)); }
auto direction() {  // non-zero, normalised
    return [](const json& j, const Path& p) { return unit(readVec<3>(j, p), p, "must not be the zero vector"); };
}
auto boolean() {
    return [](const json& j, const Path& p) {
        if (!j.is_boolean()) fail(p, "expected true or false, got " + describe(j));
        return j.get<bool>();
    };
}
auto text() {
    return [](const json& j, const Path& p) {
        if (!j.is_string()) fail(p, "expected a string, got " + describe(j));
        const std::string& s = j.get_ref<const std::string&>();
        if (s.find('\0') != std::string::npos)
            fail(p, "must not contain a NUL character (\\u0000), got " + inQuotes(s));
        return s;
    };
}
template <class E>
using Choices = std::span<const std::pair<std::string_view, E>>;
template <class E>
auto choice(Choices<E> choices) {
    return [choices](const json& j, const Path& p) {
        std::string names;
        for (const auto& [name, value] : choices) {
            if (j.is_string() && j.get<std::string>() == name) return value;
            names += (names.empty() ? "" : ", ") + inQuotes(name);
        }
        fail(p, "must be one of " + names + ", got " + (j.is_string() ? inQuotes(j.get<std::string>()) : describe(j)));
    };
}
template <class E>
std::string_view nameOf(Choices<E> choices, E value) {
    return std::find_if(choices.begin(), choices.end(), [&](const auto& c) { return c.second == value; })->first;
}

// An array read element by element; `read` takes (json, path) or (json, path, index).
template <class F>
auto listOf(F read, const Limit* limit = nullptr) {
    return [read, limit](const json& j, const Path& p) {
        if (!j.is_array()) fail(p, "expected an array, got " + describe(j));
        if (limit) checkCount(j.size(), p, *limit);
        auto one = [&](size_t i) {
            if constexpr (std::is_invocable_v<F, const json&, const Path&, size_t>) return read(j[i], element(p, i), i);
            else return read(j[i], element(p, i));
        };
        std::vector<decltype(one(0))> out;
        out.reserve(j.size());
        for (size_t i = 0; i < j.size(); ++i) out.push_back(one(i));
        return out;
    };
}

// ---------------------------------------------------------------- objects

// Optimal-string-alignment distance (edits, with transpositions) between two keys, three rows
// of the table at a time.
size_t editDistance(std::string_view a, std::string_view b) {
    std::vector<size_t> before(b.size() + 1), last(b.size() + 1), row(b.size() + 1);
    for (size_t k = 0; k <= b.size(); ++k) last[k] = k;
    for (size_t i = 1; i <= a.size(); ++i) {
        row[0] = i;
        for (size_t k = 1; k <= b.size(); ++k) {
            row[k] = std::min({last[k] + 1, row[k - 1] + 1, last[k - 1] + (a[i - 1] != b[k - 1])});
            if (i > 1 && k > 1 && a[i - 1] == b[k - 2] && a[i - 2] == b[k - 1])
                row[k] = std::min(row[k], before[k - 2] + 1);
        }
        std::swap(before, last);
        std::swap(last, row);
    }
    return last[b.size()];
}

// " (did you mean 'fov_y_deg'?)" for a close known key: a few edits away, or (with
// `subsequences`) the typed key is a subsequence of it ("fovy" -> "fov_y_deg", "dir" -> "direction");
// underscores and case aside. The distance is only computed where the lengths allow a close
// one, so a key of megabytes costs a pass over it, not a table of its length times each name's.
std::string didYouMean(const std::string& key, const std::vector<std::string>& known, bool subsequences = true) {
    auto squash = [](std::string s) {
        std::erase(s, '_');
        for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
        return s;
    };
    auto subsequence = [](const std::string& s, const std::string& of) {
        size_t i = 0;
        for (char c : of) i += i < s.size() && s[i] == c;
        return i == s.size();
    };
    const std::string k = squash(key);
    const std::string* best = nullptr;
    size_t bestDistance = 0;
    for (const std::string& candidate : known) {
        const std::string c = squash(candidate);
        const size_t allowed = std::max<size_t>(1, std::max(k.size(), c.size()) / 3);
        const size_t apart = k.size() > c.size() ? k.size() - c.size() : c.size() - k.size();
        size_t d = 0;
        bool close = false;
        if (subsequences && k.size() >= 3 && subsequence(k, c)) {
            d = apart;  // the insertions that make `c`: no fewer edits can
            close = true;
        } else if (apart <= allowed) {  // the distance is at least `apart`
            d = editDistance(k, c);
            close = d <= allowed;
        }
        if (close && (!best || d < bestDistance)) best = &candidate, bestDistance = d;
    }
    return best ? " (did you mean " + inQuotes(*best) + "?)" : "";
}

// Reads one JSON object: remembers every key asked for, and finish() rejects the others
// (keys that begin with '_' are comments).
class Obj {
public:
    Obj(const json& j, Path path) : j_(j), path_(std::move(path)) {
        if (!j.is_object()) fail(path_, "expected an object, got " + describe(j));
    }

    Path at(std::string_view key) const { return member(path_, key); }

    const json* find(const std::string& key) {
        known_.push_back(key);
        const auto it = j_.find(key);
        return it == j_.end() ? nullptr : &*it;
    }
    // A required value.
    template <class R>
    auto req(const std::string& key, R read) {
        const json* v = find(key);
        if (!v) missing({key}, at(key), "required key is missing");
        return read(*v, at(key));
    }
    // An optional value: `out` keeps its default when the key is absent. Returns presence.
    template <class T, class R>
    bool opt(const std::string& key, T& out, R read) {
        const json* v = find(key);
        if (v) out = static_cast<T>(read(*v, at(key)));
        return v != nullptr;
    }
    // A key that is known but not allowed here, e.g. `radius` on a box.
    void reject(const std::string& key, const std::string& fault) const {
        if (j_.contains(key)) fail(at(key), fault);
    }
    // Reports missing required `keys`, or rather an unknown key that looks like a typo of one.
    [[noreturn]] void missing(const std::vector<std::string>& keys, const Path& path, const std::string& fault) const {
        for (const auto& [key, value] : j_.items())
            if (const std::string hint = didYouMean(key, keys, false); unknown(key) && !hint.empty())
                fail(at(key), "unknown key " + inQuotes(key) + hint);
        fail(path, fault);
    }
    void finish() const {
        for (const auto& [key, value] : j_.items())
            if (unknown(key)) fail(at(key), "unknown key " + inQuotes(key) + didYouMean(key, known_));
    }

private:
    bool unknown(const std::string& key) const {
        return !key.starts_with('_') && std::find(known_.begin(), known_.end(), key) == known_.end();
    }

    const json& j_;
    Path path_;
    std::vector<std::string> known_;
};

// ---------------------------------------------------------------- scene sections

Camera readCamera(const json& j, const Path& p) {
    Obj o(j, p);
    Camera c;
    c.position = o.req("position", vec3(coordinate()));
    const json* lookAt = o.find("look_at");
    const json* dir = o.find("direction");
    if (lookAt && dir) fail(p, "has both 'look_at' and 'direction'; give exactly one");
    if (!lookAt && !dir) o.missing({"look_at", "direction"}, p, "needs 'look_at' or 'direction'");
    c.direction = lookAt ? unitBetween(c.position, readVec<3>(*lookAt, o.at("look_at"), coordinate()), o.at("look_at"),
                                       "must differ from position")
                         : direction()(*dir, o.at("direction"));
    const bool hasUp = o.opt("up", c.up, vec3());
    const Vec3 up = unit(c.up, o.at("up"), "must not be the zero vector");
    if (glm::length(glm::cross(up, c.direction)) < 1e-6)
        fail(o.at("up"), hasUp ? "is parallel to the view direction"
                               : "the default up [0, 0, 1] is parallel to the view direction; give another 'up'");
    o.opt("fov_y_deg", c.fovYDeg, number(exclusive(1, 179)));
    o.opt("near", c.nearClip, number(capped(above(0), limits::kSmallestNear)));  // m
    o.opt("far", c.farClip, number(capped(above(0), limits::kFarClip)));         // m
    if (c.nearClip >= c.farClip) fail(o.at("near"), "must be < far (" + str(c.farClip) + "), got " + str(c.nearClip));
    o.opt("width", c.width, integer(1, std::int64_t(limits::kImageSide.value)));  // pixels
    o.opt("height", c.height, integer(1, std::int64_t(limits::kImageSide.value)));
    o.finish();
    return c;
}

Sun readSun(const json& j, const Path& p) {
    Obj o(j, p);
    Sun s;
    o.opt("direction", s.direction, direction());
    o.opt("color", s.color, color());
    o.opt("intensity", s.intensity, intensity());
    o.finish();
    return s;
}

Sky readSky(const json& j, const Path& p) {
    Obj o(j, p);
    Sky s;
    o.opt("zenith", s.zenith, color());
    o.opt("horizon", s.horizon, color());
    o.opt("ground", s.ground, color());
    o.finish();
    return s;
}

// The extinction from liquid_water_content and droplet_effective_radius (extinctionFromWater),
// when the medium gives them instead of `extinction`.
void readWater(Obj& o, const json& j, Medium& m) {
    const bool lwc = j.contains("liquid_water_content"), reff = j.contains("droplet_effective_radius");
    if (!lwc && !reff) return;
    if (j.contains("extinction"))
        fail(o.at(lwc ? "liquid_water_content" : "droplet_effective_radius"),
             "give either 'extinction' or the pair 'liquid_water_content' and 'droplet_effective_radius', not both");
    if (!lwc || !reff)
        fail(o.at(lwc ? "droplet_effective_radius" : "liquid_water_content"),
             std::string("required key is missing: '") + (lwc ? "liquid_water_content" : "droplet_effective_radius") +
                 "' is given, and the extinction needs both");
    const double water = o.req("liquid_water_content", number());
    if (!(water > kLiquidWaterMin && water <= kLiquidWaterMax))
        fail(o.at("liquid_water_content"), "must be in (" + str(kLiquidWaterMin) + ", " + str(kLiquidWaterMax) +
                                               "] g/m^3 (cloud liquid water content), got " + str(water));
    const double radius = o.req("droplet_effective_radius", number());
    if (!(radius >= kDropletRadiusMin && radius <= kDropletRadiusMax))
        fail(o.at("droplet_effective_radius"), "must be in [" + str(kDropletRadiusMin) + ", " + str(kDropletRadiusMax) +
                                                   "] micrometres (cloud droplets), got " + str(radius));
    m.extinction = extinctionFromWater(water, radius);
    if (!withinLimit(m.extinction, limits::kExtinction))
        fail(o.at("liquid_water_content"), str(water) + " g/m^3 with droplet_effective_radius " + str(radius) +
                                               " um gives an extinction of " + str(m.extinction) +
                                               " 1/m at density 1, over the limit " + limitText(limits::kExtinction));
}

constexpr std::pair<std::string_view, Medium::Detail::Kind> kDetailKinds[] = {
    {"nephele", Medium::Detail::Kind::Nephele}, {"reference", Medium::Detail::Kind::Reference}};

Medium::Detail readDetail(const json& j, const Path& p) {
    Obj o(j, p);
    Medium::Detail d;
    o.opt("kind", d.kind, choice<Medium::Detail::Kind>(kDetailKinds));
    o.opt("erosion", d.erosion, number(inclusive(0, 4)));
    o.opt("scale", d.scale, number(inclusive(limits::kDetailSmallest, limits::kDetailScale)));        // m
    o.opt("smallest", d.smallest, number(inclusive(limits::kDetailSmallest, limits::kDetailScale)));  // m
    if (d.smallest > d.scale)
        fail(o.at("smallest"), "must be at most detail.scale (" + str(d.scale) + " m), got " + str(d.smallest));
    if (d.scale / d.smallest > limits::kDetailOctaveRatio)
        fail(o.at("smallest"), "scale / smallest is " + str(d.scale / d.smallest) + ", over " +
                                   str(limits::kDetailOctaveRatio) + " (16 octaves)");
    if (o.opt("wind", d.wind, vec3()))  // m/s
        checkLimit(glm::length(d.wind), o.at("wind"), limits::kWindSpeed);
    o.finish();
    return d;
}

Medium readMedium(const json& j, const Path& p) {
    Obj o(j, p);
    Medium m;
    o.opt("extinction", m.extinction, number(capped(atLeast(0), limits::kExtinction)));  // 1/m
    readWater(o, j, m);
    o.opt("albedo", m.albedo, number(inclusive(0, 1)));
    o.opt("hg_g", m.hgG, number(exclusive(-1, 1)));
    o.opt("noise", m.noise, number(capped(atLeast(0), limits::kNoiseAmplitude)));
    o.opt("noise_scale", m.noiseScale,
          number(capped(capped(above(0), limits::kNoiseScale), limits::kSmallestNoiseScale)));  // m
    o.opt("detail", m.detail, readDetail);
    o.finish();
    return m;
}

// The optical depth through the ellipsoid's centre along its longest axis (the largest it has).
double largestOpticalDepth(const Ellipsoid& e, const Medium& m) {
    return m.extinction * e.density * (16.0 / 15.0) * e.maxRadius();
}

Ellipsoid readEllipsoid(const json& j, const Path& p, const Medium& medium) {
    Obj o(j, p);
    Ellipsoid e;
    e.center = o.req("center", vec3(coordinate()));
    e.radii = o.req("radii", vec3(capped(capped(above(0), limits::kEllipsoidRadius), limits::kSmallestRadius)));  // m
    o.opt("rotation_deg", e.rotationDeg, vec3());
    o.opt("density", e.density, number(atLeast(0)));
    if (const double tau = largestOpticalDepth(e, medium); !withinLimit(tau, limits::kOpticalDepth))
        fail(o.at("density"), "gives an optical depth of " + str(tau) + " along the longest axis (medium.extinction " +
                                  str(medium.extinction) + " x density " + str(e.density) +
                                  " x 16/15 x the largest radius), over the limit " + limitText(limits::kOpticalDepth));
    o.finish();
    return e;
}

Cloud readCloud(const json& j, const Path& p, size_t index, const Medium& medium) {
    Obj o(j, p);
    Cloud c{"cloud" + std::to_string(index), {}};
    o.opt("name", c.name, text());
    c.ellipsoids =
        o.req("ellipsoids", listOf([&](const json& e, const Path& at) { return readEllipsoid(e, at, medium); }));
    o.finish();
    return c;
}

// L-system rules: {"F": "FF+[+F-F]"}, one-character symbols ('_' keys are comments).
std::vector<std::pair<char, std::string>> readRules(const json& j, const Path& p) {
    if (!j.is_object()) fail(p, "expected an object mapping one-character symbols to strings, got " + describe(j));
    std::vector<std::pair<char, std::string>> rules;
    for (const auto& [symbol, replacement] : j.items()) {
        if (symbol.starts_with('_')) continue;
        if (symbol.size() != 1)
            fail(member(p, symbol), "a rule's symbol must be one character, got " + inQuotes(symbol));
        rules.emplace_back(symbol[0], text()(replacement, member(p, symbol)));
    }
    return rules;
}

constexpr std::pair<std::string_view, Generator::Type> kGeneratorTypes[] = {
    {"cumulus", Generator::Type::Cumulus}, {"mesh", Generator::Type::Mesh}, {"lsystem", Generator::Type::LSystem}};
// The keys of each generator type besides the common type, name, seed and density.
const std::vector<std::string>& generatorKeys(Generator::Type type) {
    static const std::vector<std::string> cumulus{"center",     "count",  "sigma",  "clamp_lo",        "clamp_hi",
                                                  "max_radius", "aspect", "hollow", "prune_contained", "medium"};
    static const std::vector<std::string> mesh{"path", "position", "scale", "rotation_deg", "thickness_ratio"};
    static const std::vector<std::string> lsystem{"center",     "axiom", "rules",  "angle_deg",
                                                  "iterations", "step",  "radius", "jitter"};
    return type == Generator::Type::Cumulus ? cumulus : type == Generator::Type::Mesh ? mesh : lsystem;
}

constexpr std::pair<std::string_view, bool> kCumulusMedia[] = {{"scene", false}, {"cumulus", true}};

Generator readGenerator(const json& j, const Path& p, size_t index, const std::filesystem::path& sceneDir,
                        const Medium& medium) {
    using T = Generator::Type;
    Obj o(j, p);
    Generator g;
    g.type = o.req("type", choice<T>(kGeneratorTypes));
    const std::string typeName(nameOf<T>(kGeneratorTypes, g.type));
    const auto& own = generatorKeys(g.type);
    for (const auto& [_, other] : kGeneratorTypes)
        for (const std::string& key : generatorKeys(other))
            if (std::find(own.begin(), own.end(), key) == own.end())
                o.reject(key, inQuotes(key) + " is not a key of a " + typeName + " generator");

    g.name = typeName + std::to_string(index);
    o.opt("name", g.name, text());
    o.opt("seed", g.seed, seed());
    o.opt("density", g.density, number(atLeast(0)));
    switch (g.type) {
        case T::Cumulus:
            g.center = o.req("center", vec3(coordinate()));
            o.opt("count", g.count,
                  integer(1, std::int64_t(limits::kEllipsoidsPerEntry.value), &limits::kEllipsoidsPerEntry));
            o.opt("sigma", g.sigma, vec3(above(0)));  // m
            o.opt("clamp_lo", g.clampLo, vec3());     // in units of sigma
            o.opt("clamp_hi", g.clampHi, vec3());
            for (int k = 0; k < 3; ++k)
                if (!(g.clampLo[k] < g.clampHi[k]))
                    fail(element(o.at("clamp_hi"), k), "must be > clamp_lo[" + std::to_string(k) + "] (" +
                                                           str(g.clampLo[k]) + "), got " + str(g.clampHi[k]));
            o.opt("max_radius", g.maxRadius, number(capped(above(0), limits::kEllipsoidRadius)));  // m
            o.opt("aspect", g.aspect, vec3(above(0)));
            o.opt("hollow", g.hollow, boolean());
            o.opt("prune_contained", g.pruneContained, boolean());
            o.opt("medium", g.cumulusMedium, choice<bool>(kCumulusMedia));
            if (g.cumulusMedium) {  // real cumulus matter, whatever the scene's medium
                if (j.contains("density"))
                    fail(o.at("density"),
                         "give either 'density' or \"medium\": \"cumulus\" (which sets the density), not both");
                if (!(medium.extinction > 0))
                    fail(o.at("medium"), "'cumulus' sets the density to " + str(kCumulusExtinction) +
                                             " / medium.extinction, and medium.extinction is 0");
                g.density = kCumulusExtinction / medium.extinction;
            }
            break;
        case T::Mesh:
            g.path = o.req("path", text());
            if (g.path.empty()) fail(o.at("path"), "must not be empty");
            g.resolvedPath = (sceneDir / g.path).string();
            if (auto opened = detail::openRegularFile(g.resolvedPath, limits::kObjFileBytes, inQuotes(g.resolvedPath));
                !opened.file)
                fail(o.at("path"), opened.fault);
            o.opt("position", g.position, vec3(coordinate()));  // m
            o.opt("scale", g.scale, number(above(0)));
            o.opt("rotation_deg", g.rotationDeg, vec3());
            o.opt("thickness_ratio", g.thicknessRatio, number(above(0)));
            break;
        case T::LSystem:
            g.center = o.req("center", vec3(coordinate()));
            g.axiom = o.req("axiom", text());
            if (g.axiom.empty()) fail(o.at("axiom"), "must not be empty");
            g.rules = o.req("rules", readRules);
            o.opt("angle_deg", g.angleDeg, number());
            o.opt("iterations", g.iterations, integer(0, 8));
            o.opt("step", g.step, number(above(0)));                                        // m
            o.opt("radius", g.radius, number(capped(above(0), limits::kEllipsoidRadius)));  // m
            o.opt("jitter", g.jitter, number(halfOpen(0, 1)));
            break;
    }
    o.finish();
    return g;
}

CityGlow readCityGlow(const json& j, const Path& p) {
    Obj o(j, p);
    CityGlow g;
    o.opt("color", g.color, color());
    o.opt("strength", g.strength, intensity());
    o.finish();
    return g;
}

Layer readLayer(const json& j, const Path& p, const Medium& medium) {
    Obj o(j, p);
    Layer l;
    l.base = o.req("base", number(coordinate()));                                         // m
    l.thickness = o.req("thickness", number(capped(above(0), limits::kLayerThickness)));  // m
    o.opt("coverage", l.coverage, number(inclusive(0, 1)));
    o.opt("density", l.density, number(inclusive(0, 1)));
    if (const double tau = medium.extinction * l.density * l.thickness; !withinLimit(tau, limits::kLayerOpticalDepth))
        fail(o.at("thickness"), "gives an optical depth of " + str(tau) + " through the layer (medium.extinction " +
                                    str(medium.extinction) + " x density " + str(l.density) + " x thickness " +
                                    str(l.thickness) + " m), over the limit " + limitText(limits::kLayerOpticalDepth));
    if (o.opt("wind", l.wind, vec2()))  // m/s
        checkLimit(glm::length(l.wind), o.at("wind"), limits::kWindSpeed);
    o.opt("extent", l.extent, number(capped(above(0), limits::kLayerExtent)));  // m
    o.opt("seed", l.seed, seed());
    o.opt("near_lod", l.nearLod, boolean());
    if (const json* glow = o.find("city_glow")) l.cityGlow = readCityGlow(*glow, o.at("city_glow"));
    o.finish();
    return l;
}

Skylight readSkylight(const json& j, const Path& p) {
    Obj o(j, p);
    Skylight s;
    s.direction = o.req("direction", direction());
    o.opt("color", s.color, color());
    o.opt("intensity", s.intensity, intensity());
    o.finish();
    return s;
}

Lightning readLightning(const json& j, const Path& p) {
    Obj o(j, p);
    Lightning l;
    l.position = o.req("position", vec3(coordinate()));
    l.intensity = o.req("intensity", intensity());
    o.opt("start", l.start, number(timeOfDay()));                            // s
    o.opt("duration", l.duration, number(capped(above(0), limits::kTime)));  // s
    o.finish();
    return l;
}

constexpr std::pair<std::string_view, Object::Type> kObjectTypes[] = {{"box", Object::Type::Box},
                                                                      {"sphere", Object::Type::Sphere}};

Object readObject(const json& j, const Path& p) {
    Obj o(j, p);
    Object b;
    b.type = o.req("type", choice<Object::Type>(kObjectTypes));
    const bool box = b.type == Object::Type::Box;
    o.reject(box ? "radius" : "size", box ? "'radius' is not a key of a box (it has a 'size')"
                                          : "'size' is not a key of a sphere (it has a 'radius')");
    b.center = o.req("center", vec3(coordinate()));
    if (box) b.size = o.req("size", vec3(capped(above(0), limits::kObjectSize)));    // m, full edge lengths
    else b.radius = o.req("radius", number(capped(above(0), limits::kObjectSize)));  // m
    o.opt("rotation_deg", b.rotationDeg, vec3());
    o.opt("color", b.color, color());
    o.finish();
    return b;
}

constexpr std::pair<std::string_view, ObjectLight> kObjectLights[] = {{"sun", ObjectLight::Sun},
                                                                      {"all", ObjectLight::All}};

Keyframe readKeyframe(const json& j, const Path& p) {
    Obj o(j, p);
    Keyframe k;
    k.t = o.req("t", number(timeOfDay()));  // s
    k.position = o.req("position", vec3(coordinate()));
    k.lookAt = o.req("look_at", vec3(coordinate()));
    unitBetween(k.position, k.lookAt, o.at("look_at"), "must differ from position");
    o.finish();
    return k;
}

// The explicit ellipsoids of `clouds` (counted before any is read, so that a huge file fails fast).
void checkEllipsoidCount(const json& clouds) {
    if (!clouds.is_array()) return;  // listOf reports it
    std::size_t n = 0;
    for (const json& c : clouds)
        if (const auto e = c.is_object() ? c.find("ellipsoids") : c.end(); e != c.end() && e->is_array())
            n += e->size();
    checkCount(n, "clouds", limits::kEllipsoids, "ellipsoids");
}

std::string vecText(const Vec3& v) { return "[" + str(v.x) + ", " + str(v.y) + ", " + str(v.z) + "]"; }

// A keyframe that looks along camera.up has no image orientation (makeView would throw
// later, without a file or path); nor has a path segment whose interpolated view
// (look_at - position, linear in time as in cameraAt) turns through camera.up on its way.
void checkPathViews(const std::vector<Keyframe>& path, const Vec3& up) {
    const Vec3 u = glm::normalize(up);
    auto parallel = [&](const Vec3& view) { return glm::length(glm::cross(glm::normalize(view), u)) < 1e-6; };
    const std::string along = " (camera.up is " + vecText(up) + ")";
    for (size_t i = 0; i < path.size(); ++i)
        if (parallel(path[i].lookAt - path[i].position))
            fail(member(element("path", i), "look_at"), "the view from position to look_at is parallel to camera.up" +
                                                            along + "; look elsewhere or give another 'up'");
    for (size_t i = 1; i < path.size(); ++i) {
        const Vec3 va = path[i - 1].lookAt - path[i - 1].position, vb = path[i].lookAt - path[i].position;
        // cross(view(s), u) = (1 - s) a + s b: its smallest length, where the view comes closest to u.
        const Vec3 a = glm::cross(va, u), b = glm::cross(vb, u), d = a - b;
        if (glm::dot(d, d) == 0) continue;
        const double s = std::clamp(glm::dot(a, d) / glm::dot(d, d), 0.0, 1.0);
        if (s > 0 && s < 1 && parallel(glm::mix(va, vb, s)))
            fail(element("path", i), "between t = " + str(path[i - 1].t) + " and t = " + str(path[i].t) +
                                         " the view turns through camera.up" + along +
                                         " (at t = " + str(glm::mix(path[i - 1].t, path[i].t, s)) +
                                         "); add a keyframe that looks elsewhere between them");
    }
}

Scene readScene(const json& j, const std::string& file) {
    if (!j.is_object()) fail("", "expected a JSON object at the top level, got " + describe(j));
    Obj o(j, "");
    constexpr int kVersion = 1;
    const long long version = o.req("cloudscene", integer(INT_MIN, INT_MAX));
    if (version != kVersion)
        fail("cloudscene", "unsupported cloudscene version " + std::to_string(version) +
                               "; this Nephele reads version " + std::to_string(kVersion));
    const std::filesystem::path sceneDir = std::filesystem::path(file).parent_path();
    Scene s;
    s.file = file;
    s.camera = o.req("camera", readCamera);
    o.opt("sun", s.sun, readSun);
    o.opt("sky", s.sky, readSky);
    o.opt("medium", s.medium, readMedium);
    if (const json* clouds = o.find("clouds")) checkEllipsoidCount(*clouds);
    o.opt(
        "clouds", s.clouds,
        listOf([&](const json& c, const Path& p, size_t i) { return readCloud(c, p, i, s.medium); }, &limits::kClouds));
    o.opt("generate", s.generators,
          listOf([&](const json& g, const Path& p, size_t i) { return readGenerator(g, p, i, sceneDir, s.medium); },
                 &limits::kGenerateEntries));
    o.opt("layers", s.layers,
          listOf([&](const json& l, const Path& p) { return readLayer(l, p, s.medium); }, &limits::kLayers));
    if (const json* light = o.find("skylight")) s.skylight = readSkylight(*light, o.at("skylight"));
    o.opt("lightning", s.lightning, listOf(readLightning, &limits::kLightningFlashes));
    o.opt("objects", s.objects, listOf(readObject, &limits::kObjects));
    o.opt("object_light", s.objectLight, choice<ObjectLight>(kObjectLights));
    o.opt("path", s.path, listOf(readKeyframe, &limits::kKeyframes));
    for (size_t i = 1; i < s.path.size(); ++i)
        if (!(s.path[i].t > s.path[i - 1].t))
            fail(member(element("path", i), "t"),
                 "must be > the previous keyframe's t (" + str(s.path[i - 1].t) + "), got " + str(s.path[i].t));
    checkPathViews(s.path, s.camera.up);
    o.finish();
    return s;
}

}  // namespace

Scene loadScene(const std::string& file) { return parseScene(readSceneText(file), file); }

Scene parseScene(const std::string& text, const std::string& file) {
    try {
        checkCount(text.size(), "", limits::kSceneFileBytes, "bytes");
        Scene scene = readScene(parseJson(text), file);
        expandGenerators(scene);  // design.md: generate entries expanded to ellipsoids on load
        return scene;
    } catch (const Invalid& e) {
        throw SceneError(file, e.path, e.fault);
    }
}

void checkJsonText(const std::string& text, const std::string& file) {
    try {
        checkCount(text.size(), "", limits::kSceneFileBytes, "bytes");
        parseJson(text);
    } catch (const Invalid& e) {
        throw SceneError(file, e.path, e.fault);
    }
}

std::string readSceneText(const std::string& file) {
    std::string text;
    if (auto fault = detail::readRegularFile(file, limits::kSceneFileBytes, &text)) throw SceneError(file, "", *fault);
    return text;
}

glm::dmat3 rotationFromDegrees(const Vec3& deg) {
    const Vec3 r = glm::radians(deg);
    const double cx = std::cos(r.x), sx = std::sin(r.x);
    const double cy = std::cos(r.y), sy = std::sin(r.y);
    const double cz = std::cos(r.z), sz = std::sin(r.z);
    // glm matrices are given column by column.
    const glm::dmat3 rx(1, 0, 0, 0, cx, sx, 0, -sx, cx);
    const glm::dmat3 ry(cy, 0, -sy, 0, 1, 0, sy, 0, cy);
    const glm::dmat3 rz(cz, sz, 0, -sz, cz, 0, 0, 0, 1);
    return rz * ry * rx;
}

Scene sunOnly(Scene scene) {
    scene.sky.zenith = scene.sky.horizon = scene.sky.ground = Vec3(0.0);
    return scene;
}

Scene skyOnly(Scene scene) {
    scene.sun.intensity = 0;
    return scene;
}

Camera cameraAt(const Scene& scene, double t) {
    Camera cam = scene.camera;
    const std::vector<Keyframe>& path = scene.path;
    if (path.empty()) return cam;
    // The first keyframe after t; t lies between it and the one before (clamped at the ends).
    const auto next =
        std::upper_bound(path.begin(), path.end(), t, [](double v, const Keyframe& k) { return v < k.t; });
    const Keyframe& a = next == path.begin() ? path.front() : *(next - 1);
    const Keyframe& b = next == path.end() ? path.back() : *next;
    const double s = b.t > a.t ? std::clamp((t - a.t) / (b.t - a.t), 0.0, 1.0) : 0.0;
    cam.position = glm::mix(a.position, b.position, s);
    const Vec3 view = glm::mix(a.lookAt, b.lookAt, s) - cam.position;
    // Where the interpolated look_at meets the position, keep the direction of keyframe a.
    cam.direction = glm::normalize(glm::length(view) > 0 ? view : a.lookAt - a.position);
    return cam;
}

}  // namespace nephele
