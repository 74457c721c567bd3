/*---------------------------------------------------------------------------*\
    whale-adapter: the GAMG agglomeration's direction set back to forward
    whenever the mesh moves (see gamgRestartOrder.H)
\*---------------------------------------------------------------------------*/

#include "gamgRestartOrder.H"
#include "pairGAMGAgglomeration.H"

namespace Foam
{
defineTypeNameAndDebug(gamgRestartOrder, 0);

namespace gamgRestartOrderAccess
{
// pairGAMGAgglomeration::forward_ is private. An explicit instantiation
// may name a private member (C++ [temp.explicit]: "the usual access
// checking rules do not apply to names used to specify explicit
// instantiations"); the friend it defines hands out the flag's address.
bool* forwardFlag();

template<bool* Flag>
struct pairDirection
{
    friend bool* forwardFlag()
    {
        return Flag;
    }
};

template struct pairDirection<&pairGAMGAgglomeration::forward_>;
}
}


// * * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * //

Foam::gamgRestartOrder::gamgRestartOrder(const polyMesh& mesh) :
    MeshObject<polyMesh, Foam::MoveableMeshObject, gamgRestartOrder>(mesh)
{
    startForward();
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

bool Foam::gamgRestartOrder::movePoints()
{
    startForward();
    return true;
}


void Foam::gamgRestartOrder::startForward()
{
    *gamgRestartOrderAccess::forwardFlag() = true;
}
