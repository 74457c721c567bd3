/*---------------------------------------------------------------------------*\
    whale-adapter: one patch's points of all ranks, merged
    (see mergedPatchPoints.H)
\*---------------------------------------------------------------------------*/

#include "mergedPatchPoints.H"
#include "DynamicList.H"
#include "Pstream.H"
#include <algorithm>
#include <numeric>

// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::mergedPatchPoints::mergedPatchPoints(const pointField& mine) :
    slots_(Pstream::nProcs()),
    points_(),
    nGathered_(0)
{
    // Every rank's patch points, undeformed
    List<pointField> allPts(Pstream::nProcs());
    allPts[Pstream::myProcNo()] = mine;
    Pstream::gatherList(allPts);
    Pstream::scatterList(allPts);

    label nAll = 0;
    forAll(allPts, proci)
    {
        nAll += allPts[proci].size();
    }
    pointField all(nAll);
    {
        label k = 0;
        forAll(allPts, proci)
        {
            for (const point& x : allPts[proci])
            {
                all[k++] = x;
            }
        }
    }
    nGathered_ = nAll;

    // Sort lexicographically, merge exact duplicates: independent of the
    // decomposition
    labelList order(nAll);
    std::iota(order.begin(), order.end(), 0);
    auto less = [&all](label a, label b)
    {
        const point& pa = all[a];
        const point& pb = all[b];
        if (pa.x() != pb.x()) return pa.x() < pb.x();
        if (pa.y() != pb.y()) return pa.y() < pb.y();
        return pa.z() < pb.z();
    };
    std::stable_sort(order.begin(), order.end(), less);

    labelList slotOf(nAll);
    DynamicList<point> merged(nAll);
    forAll(order, i)
    {
        const label a = order[i];
        if (i == 0 || all[a] != all[order[i - 1]])
        {
            merged.append(all[a]);
        }
        slotOf[a] = merged.size() - 1;
    }
    points_.transfer(merged);

    {
        label k = 0;
        forAll(allPts, proci)
        {
            slots_[proci].setSize(allPts[proci].size());
            forAll(allPts[proci], i)
            {
                slots_[proci][i] = slotOf[k++];
            }
        }
    }
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

template<class Type>
Foam::tmp<Foam::Field<Type>>
Foam::mergedPatchPoints::gather(const Field<Type>& mine, const bool add) const
{
    List<Field<Type>> all(Pstream::nProcs());
    all[Pstream::myProcNo()] = mine;
    Pstream::gatherList(all);
    Pstream::scatterList(all);

    tmp<Field<Type>> tout(new Field<Type>(points_.size(), Zero));
    Field<Type>& out = tout.ref();
    forAll(all, proci)
    {
        const labelList& slots = slots_[proci];
        if (all[proci].size() != slots.size())
        {
            FatalErrorInFunction
                << "rank " << proci << " sent " << all[proci].size()
                << " patch point values, expected " << slots.size()
                << exit(FatalError);
        }
        forAll(slots, i)
        {
            if (add)
            {
                out[slots[i]] += all[proci][i];
            }
            else
            {
                out[slots[i]] = all[proci][i];
            }
        }
    }
    return tout;
}


Foam::tmp<Foam::vectorField> Foam::mergedPatchPoints::merge(
    const vectorField& mine
) const
{
    return gather(mine, false);
}


Foam::tmp<Foam::scalarField> Foam::mergedPatchPoints::mergeSum(
    const scalarField& mine
) const
{
    return gather(mine, true);
}

// ************************************************************************* //
