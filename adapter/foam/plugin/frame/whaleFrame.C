/*---------------------------------------------------------------------------*\
    whaleFrame: the whale's frame velocity and acceleration, registered on
    the mesh (see whaleFrame.H).
\*---------------------------------------------------------------------------*/

#include "whaleFrame.H"
#include "Time.H"

// * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * * //

namespace Foam
{
namespace whaleFrame
{

const word velocityName("whaleFrameVelocity");
const word accelerationName("whaleFrameAcceleration");

namespace
{

void setOne(
    const objectRegistry& db,
    const word& name,
    const dimensionSet& dims,
    const vector& value
)
{
    auto* ptr = const_cast<uniformDimensionedVectorField*>(
        db.findObject<uniformDimensionedVectorField>(name)
    );
    if (!ptr)
    {
        ptr = new uniformDimensionedVectorField(
            IOobject(
                name,
                db.time().timeName(),
                db,
                IOobject::NO_READ,
                IOobject::NO_WRITE
            ),
            dimensionedVector(name, dims, Zero)
        );
        ptr->store();
    }
    ptr->value() = value;
}

} // End anonymous namespace


void set(
    const objectRegistry& db,
    const vector& velocity,
    const vector& acceleration
)
{
    setOne(db, velocityName, dimVelocity, velocity);
    setOne(db, accelerationName, dimAcceleration, acceleration);
}


const uniformDimensionedVectorField* velocity(const objectRegistry& db)
{
    return db.findObject<uniformDimensionedVectorField>(velocityName);
}


const uniformDimensionedVectorField* acceleration(const objectRegistry& db)
{
    return db.findObject<uniformDimensionedVectorField>(accelerationName);
}

} // End namespace whaleFrame
} // End namespace Foam

// ************************************************************************* //
