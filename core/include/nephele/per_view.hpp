// GPU resources sized to a view (depth copies, reduced and accumulation targets, atlases),
// kept per size: display channels of different sizes drawn every frame then reallocate
// nothing, and channels of the same size, drawn one after the other, share them.
#pragma once

#include "nephele/api.hpp"
#include <glm/glm.hpp>

#include <cstddef>
#include <cstdint>
#include <list>
#include <tuple>
#include <utility>

NEPHELE_API_BEGIN
namespace nephele {

template <class T, class Key = glm::ivec2>
class PerViewCache {
public:
    explicit PerViewCache(std::size_t capacity = 8) : capacity_(capacity) {}

    // The resources for views of `size` (default-constructed the first time). The least
    // recently used beyond `capacity` sizes are dropped.
    T& get(Key size) {
        for (auto it = entries_.begin(); it != entries_.end(); ++it)
            if (it->first == size) {
                entries_.splice(entries_.begin(), entries_, it);  // most recent first
                return entries_.front().second;
            }
        entries_.emplace_front(std::piecewise_construct, std::forward_as_tuple(size), std::forward_as_tuple());
        if (entries_.size() > capacity_) entries_.pop_back();
        return entries_.front().second;
    }
    std::size_t size() const { return entries_.size(); }

private:
    std::size_t capacity_;
    std::list<std::pair<Key, T>> entries_;
};

}  // namespace nephele
NEPHELE_API_END
