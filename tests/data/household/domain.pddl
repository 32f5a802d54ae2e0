; A mobile manipulator in a small house: move between rooms, carry one item, open and close
; containers, switch appliances, wash items at a sink. Written for hbtp's generated-demonstration tests.
(define (domain household)
  (:requirements :strips :typing :action-costs)
  (:types room item container appliance)
  (:predicates
    (robot-at ?r - room) (connected ?a ?b - room)
    (item-at ?i - item ?r - room) (holding ?i - item) (hand-empty)
    (container-at ?c - container ?r - room) (opened ?c - container) (closed ?c - container)
    (inside ?i - item ?c - container)
    (appliance-at ?a - appliance ?r - room) (switched-on ?a - appliance) (switched-off ?a - appliance)
    (sink-at ?r - room) (clean ?i - item))
  (:functions (total-cost) - number)
  (:action move
    :parameters (?from ?to - room)
    :precondition (and (robot-at ?from) (connected ?from ?to))
    :effect (and (robot-at ?to) (not (robot-at ?from)) (increase (total-cost) 3)))
  (:action pick
    :parameters (?i - item ?r - room)
    :precondition (and (robot-at ?r) (item-at ?i ?r) (hand-empty))
    :effect (and (holding ?i) (not (item-at ?i ?r)) (not (hand-empty)) (increase (total-cost) 1)))
  (:action place
    :parameters (?i - item ?r - room)
    :precondition (and (robot-at ?r) (holding ?i))
    :effect (and (item-at ?i ?r) (hand-empty) (not (holding ?i)) (increase (total-cost) 1)))
  (:action open
    :parameters (?c - container ?r - room)
    :precondition (and (robot-at ?r) (container-at ?c ?r) (closed ?c) (hand-empty))
    :effect (and (opened ?c) (not (closed ?c)) (increase (total-cost) 1)))
  (:action close
    :parameters (?c - container ?r - room)
    :precondition (and (robot-at ?r) (container-at ?c ?r) (opened ?c) (hand-empty))
    :effect (and (closed ?c) (not (opened ?c)) (increase (total-cost) 1)))
  (:action put-in
    :parameters (?i - item ?c - container ?r - room)
    :precondition (and (robot-at ?r) (container-at ?c ?r) (opened ?c) (holding ?i))
    :effect (and (inside ?i ?c) (hand-empty) (not (holding ?i)) (increase (total-cost) 1)))
  (:action take-out
    :parameters (?i - item ?c - container ?r - room)
    :precondition (and (robot-at ?r) (container-at ?c ?r) (opened ?c) (inside ?i ?c) (hand-empty))
    :effect (and (holding ?i) (not (inside ?i ?c)) (not (hand-empty)) (increase (total-cost) 1)))
  (:action switch-on
    :parameters (?a - appliance ?r - room)
    :precondition (and (robot-at ?r) (appliance-at ?a ?r) (switched-off ?a) (hand-empty))
    :effect (and (switched-on ?a) (not (switched-off ?a)) (increase (total-cost) 1)))
  (:action switch-off
    :parameters (?a - appliance ?r - room)
    :precondition (and (robot-at ?r) (appliance-at ?a ?r) (switched-on ?a) (hand-empty))
    :effect (and (switched-off ?a) (not (switched-on ?a)) (increase (total-cost) 1)))
  (:action wash
    :parameters (?i - item ?r - room)
    :precondition (and (robot-at ?r) (sink-at ?r) (holding ?i))
    :effect (and (clean ?i) (increase (total-cost) 2))))
