/*---------------------------------------------------------------------------*\
    whale-adapter: kd-tree for K nearest neighbours (see pointKdTree.H)
\*---------------------------------------------------------------------------*/

#include "pointKdTree.H"
#include <algorithm>

// * * * * * * * * * * * * * Private Member Functions  * * * * * * * * * * * //

void Foam::pointKdTree::build(label lo, label hi)
{
    if (hi - lo <= 1)
    {
        return;
    }

    // Axis of the largest extent of this node's points
    point bbMin(GREAT, GREAT, GREAT);
    point bbMax(-GREAT, -GREAT, -GREAT);
    for (label i = lo; i < hi; ++i)
    {
        bbMin = min(bbMin, points_[order_[i]]);
        bbMax = max(bbMax, points_[order_[i]]);
    }
    const vector span(bbMax - bbMin);
    label ax = 0;
    if (span.y() > span[ax]) ax = 1;
    if (span.z() > span[ax]) ax = 2;

    const label mid = lo + (hi - lo) / 2;
    const pointField& pts = points_;
    std::nth_element(
        order_.begin() + lo,
        order_.begin() + mid,
        order_.begin() + hi,
        [&pts, ax](label a, label b)
        {
            const scalar pa = pts[a][ax];
            const scalar pb = pts[b][ax];
            return pa < pb || (pa == pb && a < b);
        }
    );
    axis_[mid] = static_cast<unsigned char>(ax);

    build(lo, mid);
    build(mid + 1, hi);
}


void Foam::pointKdTree::search(
    label lo,
    label hi,
    const point& p,
    label k,
    std::vector<std::pair<scalar, label>>& heap
) const
{
    if (hi <= lo)
    {
        return;
    }

    const label mid = lo + (hi - lo) / 2;
    const label idx = order_[mid];
    const scalar d2 = magSqr(points_[idx] - p);

    // Max-heap on (distance, index): the worst of the k kept is at the front
    const std::pair<scalar, label> cand(d2, idx);
    if (label(heap.size()) < k)
    {
        heap.push_back(cand);
        std::push_heap(heap.begin(), heap.end());
    }
    else if (cand < heap.front())
    {
        std::pop_heap(heap.begin(), heap.end());
        heap.back() = cand;
        std::push_heap(heap.begin(), heap.end());
    }

    if (hi - lo == 1)
    {
        return;
    }

    const label ax = axis_[mid];
    const scalar delta = p[ax] - points_[idx][ax];

    // Nearer side first, the other side only if it can hold a closer point
    if (delta < 0)
    {
        search(lo, mid, p, k, heap);
        if (label(heap.size()) < k || delta * delta <= heap.front().first)
        {
            search(mid + 1, hi, p, k, heap);
        }
    }
    else
    {
        search(mid + 1, hi, p, k, heap);
        if (label(heap.size()) < k || delta * delta <= heap.front().first)
        {
            search(lo, mid, p, k, heap);
        }
    }
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::pointKdTree::pointKdTree(const pointField& points) :
    points_(points),
    order_(points.size()),
    axis_(points.size(), 0)
{
    forAll(points_, i)
    {
        order_[i] = i;
    }
    build(0, points_.size());
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void Foam::pointKdTree::knn(
    const point& p,
    label k,
    std::vector<std::pair<scalar, label>>& result
) const
{
    result.clear();
    k = std::min(k, size());
    if (k <= 0)
    {
        return;
    }
    result.reserve(k);
    search(0, size(), p, k, result);
    std::sort_heap(result.begin(), result.end());
}


// ************************************************************************* //
